#include <terrain/lodlab/screen_measure.h>
#include <terrain/roam/screen_error.h>

#include <algorithm>
#include <cmath>
#include <unordered_map>

namespace terrain::lodlab {

MeshError measureMeshError(
    std::span<const glm::dvec3> triangles,
    const Terrain& terrain,
    const roam::Camera& camera,
    const ScreenErrorOptions& options) {
    const roam::ViewMetric view(camera);
    MeshError e;
    std::vector<float> worst;
    worst.reserve(triangles.size() / 3);
    double sum = 0.0;
    for (std::size_t t = 0; t + 2 < triangles.size(); t += 3) {
        const roam::TriangleError here = roam::measureTriangle(
            view, terrain, {triangles[t], triangles[t + 1], triangles[t + 2]},
            options.min_samples_per_edge, options.samples_per_cell);
        e.samples += here.samples;
        sum += here.sum_pixels;
        if (here.worst_pixels < 0.0)
            continue; // nothing of it on screen
        ++e.triangles;
        worst.push_back(static_cast<float>(here.worst_pixels));
        e.max_pixels = std::max(e.max_pixels, here.worst_pixels);
        if (here.worst_pixels > options.tau_pixels)
            ++e.triangles_over_tau;
    }
    if (!worst.empty()) {
        const std::size_t rank =
            static_cast<std::size_t>(std::ceil(0.99 * static_cast<double>(worst.size()))) - 1;
        std::nth_element(
            worst.begin(), worst.begin() + static_cast<std::ptrdiff_t>(rank), worst.end());
        e.p99_pixels = worst[rank];
    }
    e.mean_pixels = e.samples > 0 ? sum / static_cast<double>(e.samples) : 0.0;
    return e;
}

std::int64_t
countOpenEdges(std::span<const LatticeTriangle> triangles, std::int64_t max_x, std::int64_t max_y) {
    // an edge as its two ends, the smaller first; 2^24 lattice units per axis is ample
    const auto key = [](std::int64_t ax, std::int64_t ay, std::int64_t bx, std::int64_t by) {
        if (ax > bx || (ax == bx && ay > by)) {
            std::swap(ax, bx);
            std::swap(ay, by);
        }
        const auto u = [](std::int64_t v) { return static_cast<std::uint64_t>(v) & 0xffffffu; };
        return (u(ax) << 40) ^ (u(ay) << 24) ^ (u(bx) << 16) ^ u(by) ^ (u(bx) << 48) ^
               (u(by) << 8) * 0x9e3779b97f4a7c15ull;
    };
    struct Edge {
        std::int64_t ax, ay, bx, by;
        int uses;
    };
    std::unordered_multimap<std::uint64_t, Edge> edges;
    edges.reserve(triangles.size() * 3 / 2);
    for (const LatticeTriangle& t : triangles)
        for (int k = 0; k < 3; ++k) {
            std::int64_t ax = t[static_cast<std::size_t>(2 * k)];
            std::int64_t ay = t[static_cast<std::size_t>(2 * k + 1)];
            std::int64_t bx = t[static_cast<std::size_t>((2 * k + 2) % 6)];
            std::int64_t by = t[static_cast<std::size_t>((2 * k + 3) % 6)];
            if (ax > bx || (ax == bx && ay > by)) {
                std::swap(ax, bx);
                std::swap(ay, by);
            }
            const std::uint64_t h = key(ax, ay, bx, by);
            bool found = false;
            for (auto [it, end] = edges.equal_range(h); it != end; ++it)
                if (it->second.ax == ax && it->second.ay == ay && it->second.bx == bx &&
                    it->second.by == by) {
                    ++it->second.uses;
                    found = true;
                    break;
                }
            if (!found)
                edges.emplace(h, Edge{ax, ay, bx, by, 1});
        }
    std::int64_t open = 0;
    for (const auto& [h, e] : edges) {
        if (e.uses != 1)
            continue;
        // the midpoint, doubled: strictly inside the map, or clipped away
        const std::int64_t mx = e.ax + e.bx;
        const std::int64_t my = e.ay + e.by;
        const bool border = mx <= 0 || my <= 0 || mx >= 2 * max_x || my >= 2 * max_y;
        if (!border)
            ++open;
    }
    return open;
}

} // namespace terrain::lodlab
