#include <terrain/roam/screen_error.h>
#include <terrain/surface_query.h>

#include <glm/geometric.hpp>

#include <algorithm>
#include <cmath>

namespace terrain::roam {

TriangleError measureTriangle(
    const ViewMetric& view,
    const Terrain& terrain,
    const std::array<glm::dvec3, 3>& v,
    int min_samples_per_edge,
    double samples_per_cell) {
    const double cell_metres = terrain.spec().spacingMetres();
    const double extent_x = terrain.spec().extentX();
    const double extent_y = terrain.spec().extentY();
    const double edge =
        std::max({glm::length(v[1] - v[0]), glm::length(v[2] - v[1]), glm::length(v[0] - v[2])});
    const int n = std::max(
        min_samples_per_edge, static_cast<int>(std::ceil(edge / cell_metres * samples_per_cell)));
    TriangleError t;
    for (int a = 0; a <= n; ++a) {
        for (int b = 0; a + b <= n; ++b) {
            const double wa = static_cast<double>(a) / n;
            const double wb = static_cast<double>(b) / n;
            const glm::dvec3 mesh = v[0] * wa + v[1] * wb + v[2] * (1.0 - wa - wb);
            if (mesh.x > extent_x || mesh.y > extent_y)
                continue; // padding beyond the map is clipped when drawn
            const glm::dvec3 truth{mesh.x, mesh.y, surfaceHeight(terrain, mesh.x, mesh.y)};
            const ScreenPoint sm = view.project(mesh);
            const ScreenPoint st = view.project(truth);
            if (!view.isVisible(sm) || !view.isVisible(st))
                continue;
            const double e = std::hypot(sm.x - st.x, sm.y - st.y);
            ++t.samples;
            t.sum_pixels += e;
            if (e > t.worst_pixels) {
                t.worst_pixels = e;
                t.worst_point = mesh;
            }
        }
    }
    return t;
}

ScreenErrorStats measureScreenError(
    const Tessellator& tessellator,
    const Terrain& terrain,
    const Camera& camera,
    const ScreenErrorOptions& options) {
    const ViewMetric view(camera);
    const double mpl = tessellator.metresPerLattice();
    const double mpf = tessellator.metresPerFineUnit();
    ScreenErrorStats stats;
    double sum = 0.0;
    for (std::int32_t tile = 0; tile < tessellator.tileCount(); ++tile) {
        if (!tessellator.tileVisible(tile))
            continue;
        const auto indices = tessellator.tileMesh(tile).indices();
        for (std::size_t i = 0; i + 2 < indices.size(); i += 3) {
            if (indices[i] == 0 && indices[i + 1] == 0 && indices[i + 2] == 0)
                continue; // a free slot
            std::array<glm::dvec3, 3> v{};
            std::array<LatticePoint, 3> p{};
            for (std::size_t j = 0; j < 3; ++j) {
                const TileVertex tv = tessellator.tileVertex(tile, indices[i + j]);
                p[j] = tv.position;
                v[j] = {
                    tv.position.x * mpl, tv.position.y * mpl, static_cast<double>(tv.height) * mpf};
            }
            // the finest triangles have axis-aligned legs of one lattice unit
            const bool finest = std::abs(p[1].x - p[0].x) + std::abs(p[1].y - p[0].y) <= 1 ||
                                std::abs(p[2].x - p[1].x) + std::abs(p[2].y - p[1].y) <= 1;
            ++stats.triangles;
            const TriangleError t = measureTriangle(
                view, terrain, v, options.min_samples_per_edge, options.samples_per_cell);
            const double worst_here = std::max(0.0, t.worst_pixels);
            stats.samples += t.samples;
            sum += t.sum_pixels;
            if (t.worst_pixels > stats.max_pixels) {
                stats.max_pixels = t.worst_pixels;
                stats.worst_point = t.worst_point;
            }
            if (!finest)
                stats.max_pixels_above_finest = std::max(stats.max_pixels_above_finest, worst_here);
            else if (worst_here > tessellator.options().tau_pixels)
                ++stats.finest_triangles_over_tau_bound;
        }
    }
    stats.mean_pixels = stats.samples > 0 ? sum / static_cast<double>(stats.samples) : 0.0;
    return stats;
}

} // namespace terrain::roam
