#include <terrain/lodlab/chunked_lod.h>

#include <algorithm>
#include <cmath>
#include <limits>

namespace terrain::lodlab {
namespace {

constexpr std::int32_t K = kChunkCells;
constexpr std::int64_t kChunkTriangles = 2 * K * K;
constexpr std::int64_t kIndexBytes = 12; ///< three 32-bit indices per triangle

std::size_t sz(std::int64_t v) {
    return static_cast<std::size_t>(v);
}

/// Height on a cell of corner heights h00 (a, b) .. h11 at fractions (fa, fb), with the base
/// surface's diagonal rule (base_cell.h) for a cell of parity `odd`.
double cellHeight(double h00, double h10, double h01, double h11, bool odd, double fa, double fb) {
    if (!odd) {
        if (fa >= fb)
            return h00 + (h10 - h00) * fa + (h11 - h10) * fb;
        return h00 + (h11 - h01) * fa + (h01 - h00) * fb;
    }
    if (fa + fb <= 1.0)
        return h00 + (h10 - h00) * fa + (h01 - h00) * fb;
    return h11 + (h01 - h11) * (1.0 - fa) + (h10 - h11) * (1.0 - fb);
}

} // namespace

ChunkedLod::ChunkedLod(const Terrain& terrain, const ChunkedLodOptions& options)
    : terrain_(&terrain), options_(options) {
    const WorldSpec& spec = terrain.spec();
    cells_x_ = spec.width - 1;
    cells_y_ = spec.height - 1;
    spacing_ = spec.spacingMetres();
    metres_per_unit_ = spec.metresPerUnit();
    std::int32_t step = 1;
    while (true) {
        Level l;
        l.step = step;
        l.nx = (cells_x_ + K * step - 1) / (K * step);
        l.ny = (cells_y_ + K * step - 1) / (K * step);
        const std::size_t n = sz(l.nx) * sz(l.ny);
        l.error.assign(n, 0.0f);
        l.edge_error.assign(4 * n, 0.0f);
        l.zlo.assign(n, 0.0f);
        l.zhi.assign(n, 0.0f);
        l.state.assign(n, 0);
        l.visible.assign(n, 0);
        l.loaded.assign(n, 0);
        l.reload.assign(n, 0);
        levels_.push_back(std::move(l));
        if (levels_.back().nx <= 1 && levels_.back().ny <= 1)
            break;
        step *= 2;
    }
    terrainChanged({}, true);
}

double ChunkedLod::heightAt(std::int32_t x, std::int32_t y) const {
    x = std::clamp(x, 0, cells_x_);
    y = std::clamp(y, 0, cells_y_);
    return terrain_->sample(x, y) * metres_per_unit_;
}

void ChunkedLod::terrainChanged(std::span<const CellRect> cells, bool all) {
    patch_deviation_.resize(sz(cells_x_) * sz(cells_y_));
    std::vector<CellRect> rects(cells.begin(), cells.end());
    if (all)
        rects = {CellRect{0, 0, cells_x_ - 1, cells_y_ - 1}};
    for (CellRect r : rects) {
        r.x0 = std::max(r.x0, 0);
        r.y0 = std::max(r.y0, 0);
        r.x1 = std::min(r.x1, cells_x_ - 1);
        r.y1 = std::min(r.y1, cells_y_ - 1);
        if (r.empty())
            continue;
        for (std::int32_t y = r.y0; y <= r.y1; ++y)
            for (std::int32_t x = r.x0; x <= r.x1; ++x) {
                const DetailPatch* p = terrain_->findPatch(x, y);
                patch_deviation_[sz(y) * sz(cells_x_) + sz(x)] =
                    p == nullptr ? 0.0f : static_cast<float>(p->deviation_bound * metres_per_unit_);
            }
        // the chunks whose vertices (or cells) the rectangle's vertices touch
        for (std::size_t li = 0; li < levels_.size(); ++li) {
            Level& l = levels_[li];
            const std::int32_t span = K * l.step;
            const std::int32_t cx0 = std::max(0, (r.x0 - 1) / span);
            const std::int32_t cy0 = std::max(0, (r.y0 - 1) / span);
            const std::int32_t cx1 = std::min(l.nx - 1, (r.x1 + 1) / span);
            const std::int32_t cy1 = std::min(l.ny - 1, (r.y1 + 1) / span);
            for (std::int32_t cy = cy0; cy <= cy1; ++cy)
                for (std::int32_t cx = cx0; cx <= cx1; ++cx) {
                    computeChunk(static_cast<std::int32_t>(li), cx, cy);
                    if (l.loaded[at(l, cx, cy)] != 0)
                        l.reload[at(l, cx, cy)] = 1;
                }
        }
    }
}

void ChunkedLod::computeChunk(std::int32_t level, std::int32_t x, std::int32_t y) {
    Level& l = levels_[sz(level)];
    const std::int32_t s = l.step;
    const std::int32_t ox = x * K * s;
    const std::int32_t oy = y * K * s;
    // the chunk's vertices, plain and with every odd edge vertex on its edge's straight line
    std::array<double, kChunkVertices> plain{};
    const auto v = [](std::int32_t a, std::int32_t b) { return sz(b) * (K + 1) + sz(a); };
    for (std::int32_t b = 0; b <= K; ++b)
        for (std::int32_t a = 0; a <= K; ++a)
            plain[v(a, b)] = heightAt(ox + a * s, oy + b * s);
    double lo = std::numeric_limits<double>::infinity();
    double hi = -lo;
    double deviation = 0.0;
    const std::int32_t x_end = std::min(ox + K * s, cells_x_);
    const std::int32_t y_end = std::min(oy + K * s, cells_y_);
    for (std::int32_t gy = oy; gy <= y_end; ++gy)
        for (std::int32_t gx = ox; gx <= x_end; ++gx) {
            const double h = heightAt(gx, gy);
            lo = std::min(lo, h);
            hi = std::max(hi, h);
            if (gx < cells_x_ && gy < cells_y_)
                deviation =
                    std::max<double>(deviation, patch_deviation_[sz(gy) * sz(cells_x_) + sz(gx)]);
        }
    // the largest |mesh - base surface| over the base vertices of [gx0, gx1] x [gy0, gy1]
    const auto errorOver = [&](const std::array<double, kChunkVertices>& hs, std::int32_t gx0,
                               std::int32_t gx1, std::int32_t gy0, std::int32_t gy1) {
        double error = 0.0;
        for (std::int32_t gy = gy0; gy <= std::min(gy1, y_end); ++gy) {
            const std::int32_t b = std::min((gy - oy) / s, K - 1);
            const double fb = static_cast<double>(gy - oy - b * s) / s;
            for (std::int32_t gx = gx0; gx <= std::min(gx1, x_end); ++gx) {
                const std::int32_t a = std::min((gx - ox) / s, K - 1);
                const double fa = static_cast<double>(gx - ox - a * s) / s;
                const double m = cellHeight(
                    hs[v(a, b)], hs[v(a + 1, b)], hs[v(a, b + 1)], hs[v(a + 1, b + 1)],
                    ((a + b) & 1) != 0, fa, fb);
                error = std::max(error, std::abs(m - heightAt(gx, gy)));
            }
        }
        return error;
    };
    const std::size_t i = at(l, x, y);
    // float rounding must not make a stored bound smaller than the exact one
    const auto up = [](double e) {
        return e == 0.0 ? 0.0f : std::nextafter(static_cast<float>(e), 1e30f);
    };
    l.error[i] =
        s == 1 ? up(deviation) : up(errorOver(plain, ox, ox + K * s, oy, oy + K * s) + deviation);
    // a stitched edge changes the triangles of its strip, one chunk cell deep
    const std::int32_t x1 = ox + K * s;
    const std::int32_t y1 = oy + K * s;
    const std::array<std::array<std::int32_t, 4>, 4> strips = {
        {{ox, x1, oy, oy + s}, {x1 - s, x1, oy, y1}, {ox, x1, y1 - s, y1}, {ox, ox + s, oy, y1}}};
    for (std::size_t e = 0; e < 4; ++e) {
        std::array<double, kChunkVertices> hs = plain;
        for (std::int32_t k = 1; k < K; k += 2) {
            const auto [ca, cb, pa, pb, na, nb] =
                e == 0   ? std::array<std::int32_t, 6>{k, 0, k - 1, 0, k + 1, 0}
                : e == 1 ? std::array<std::int32_t, 6>{K, k, K, k - 1, K, k + 1}
                : e == 2 ? std::array<std::int32_t, 6>{k, K, k - 1, K, k + 1, K}
                         : std::array<std::int32_t, 6>{0, k, 0, k - 1, 0, k + 1};
            hs[v(ca, cb)] = 0.5 * (plain[v(pa, pb)] + plain[v(na, nb)]);
        }
        const auto& r = strips[e];
        l.edge_error[i * 4 + e] = up(errorOver(hs, r[0], r[1], r[2], r[3]) + deviation);
    }
    l.zlo[i] = std::nextafter(static_cast<float>(lo - deviation), -1e30f);
    l.zhi[i] = std::nextafter(static_cast<float>(hi + deviation), 1e30f);
}

double ChunkedLod::chunkError(std::int32_t level, std::int32_t x, std::int32_t y) const {
    const Level& l = levels_[sz(level)];
    return l.error[at(l, x, y)];
}

roam::Box ChunkedLod::boxOf(std::int32_t level, std::int32_t x, std::int32_t y) const {
    const Level& l = levels_[sz(level)];
    const std::int32_t span = K * l.step;
    const std::size_t i = at(l, x, y);
    roam::Box box;
    box.lo = {x * span * spacing_, y * span * spacing_, l.zlo[i]};
    box.hi = {
        std::min(x * span + span, cells_x_) * spacing_,
        std::min(y * span + span, cells_y_) * spacing_, l.zhi[i]};
    return box;
}

std::int32_t ChunkedLod::leafLevelAt(std::int64_t x2, std::int64_t y2) const {
    if (x2 < 0 || y2 < 0 || x2 > 2 * std::int64_t{cells_x_} || y2 > 2 * std::int64_t{cells_y_})
        return -1;
    for (std::int32_t li = levels() - 1; li >= 0; --li) {
        const Level& l = levels_[sz(li)];
        const std::int64_t span2 = 2 * std::int64_t{K} * l.step;
        const auto cx = static_cast<std::int32_t>(std::min<std::int64_t>(x2 / span2, l.nx - 1));
        const auto cy = static_cast<std::int32_t>(std::min<std::int64_t>(y2 / span2, l.ny - 1));
        const std::uint8_t st = l.state[at(l, cx, cy)];
        if (st == kLeaf)
            return li;
        if (st != kSplit)
            return -1;
    }
    return -1;
}

std::array<bool, 4>
ChunkedLod::stitching(std::int32_t level, std::int32_t x, std::int32_t y) const {
    const std::int64_t span2 = 2 * std::int64_t{K} * levels_[sz(level)].step;
    const std::int64_t x0 = x * span2;
    const std::int64_t y0 = y * span2;
    // a point of each edge inside the map (a coarser neighbour covers the whole edge; the part
    // beyond the map is clipped when drawn)
    const std::int64_t mx = std::min(x0 + span2 / 2, 2 * std::int64_t{cells_x_} - 1);
    const std::int64_t my = std::min(y0 + span2 / 2, 2 * std::int64_t{cells_y_} - 1);
    const std::array<std::int32_t, 4> n = {
        leafLevelAt(mx, y0 - 1), leafLevelAt(x0 + span2 + 1, my), leafLevelAt(mx, y0 + span2 + 1),
        leafLevelAt(x0 - 1, my)};
    return {n[0] > level, n[1] > level, n[2] > level, n[3] > level};
}

void ChunkedLod::split(std::int32_t level, std::int32_t x, std::int32_t y) {
    Level& l = levels_[sz(level)];
    l.state[at(l, x, y)] = kSplit;
    Level& c = levels_[sz(level - 1)];
    for (std::int32_t dy = 0; dy < 2; ++dy)
        for (std::int32_t dx = 0; dx < 2; ++dx) {
            const std::int32_t cx = 2 * x + dx;
            const std::int32_t cy = 2 * y + dy;
            if (cx < c.nx && cy < c.ny)
                c.state[at(c, cx, cy)] = kLeaf;
        }
}

ChunkedFrame ChunkedLod::update(const roam::Camera& camera) {
    ++frame_;
    ChunkedFrame f;
    const roam::ViewMetric view(camera);
    for (Level& l : levels_) {
        std::fill(l.state.begin(), l.state.end(), std::uint8_t{0});
        std::fill(l.visible.begin(), l.visible.end(), std::uint8_t{0});
    }
    // best-first refinement under the cap
    heap_.clear();
    const std::int32_t top = levels() - 1;
    std::int64_t triangles = 0;
    const auto push = [&](std::int32_t level, std::int32_t x, std::int32_t y) {
        const Level& l = levels_[sz(level)];
        const double p = view.screenError(boxOf(level, x, y), l.error[at(l, x, y)]);
        heap_.push_back({p, level, x, y});
        std::push_heap(heap_.begin(), heap_.end());
        ++f.nodes_visited;
    };
    for (std::int32_t y = 0; y < levels_[sz(top)].ny; ++y)
        for (std::int32_t x = 0; x < levels_[sz(top)].nx; ++x) {
            levels_[sz(top)].state[at(levels_[sz(top)], x, y)] = kLeaf;
            triangles += kChunkTriangles;
            push(top, x, y);
        }
    while (!heap_.empty()) {
        std::pop_heap(heap_.begin(), heap_.end());
        const Candidate c = heap_.back();
        heap_.pop_back();
        if (c.priority <= options_.tau_pixels)
            break; // every other is within tau too
        if (c.level == 0)
            continue;
        if (triangles + 3 * kChunkTriangles > options_.max_triangles) {
            f.capped = true;
            continue;
        }
        split(c.level, c.x, c.y);
        const Level& cl = levels_[sz(c.level - 1)];
        for (std::int32_t dy = 0; dy < 2; ++dy)
            for (std::int32_t dx = 0; dx < 2; ++dx)
                if (2 * c.x + dx < cl.nx && 2 * c.y + dy < cl.ny) {
                    push(c.level - 1, 2 * c.x + dx, 2 * c.y + dy);
                    triangles += kChunkTriangles;
                }
        triangles -= kChunkTriangles;
    }
    // leaves, then the 2:1 restriction: a leaf whose neighbour is two or more levels coarser
    // splits that neighbour
    leaves_.clear();
    for (std::int32_t li = 0; li <= top; ++li) {
        const Level& l = levels_[sz(li)];
        for (std::int32_t y = 0; y < l.ny; ++y)
            for (std::int32_t x = 0; x < l.nx; ++x)
                if (l.state[at(l, x, y)] == kLeaf)
                    leaves_.push_back({li, x, y});
    }
    for (std::size_t i = 0; i < leaves_.size(); ++i) {
        const auto [li, x, y] = leaves_[i];
        const Level& l = levels_[sz(li)];
        if (l.state[at(l, x, y)] != kLeaf)
            continue;
        const std::int64_t span2 = 2 * std::int64_t{K} * l.step;
        const std::int64_t x0 = x * span2;
        const std::int64_t y0 = y * span2;
        const std::int64_t mx = std::min(x0 + span2 / 2, 2 * std::int64_t{cells_x_} - 1);
        const std::int64_t my = std::min(y0 + span2 / 2, 2 * std::int64_t{cells_y_} - 1);
        const std::array<std::array<std::int64_t, 2>, 4> outside = {
            {{mx, y0 - 1}, {x0 + span2 + 1, my}, {mx, y0 + span2 + 1}, {x0 - 1, my}}};
        const roam::Box box = boxOf(li, x, y);
        for (std::size_t e = 0; e < 4; ++e) {
            const auto& p = outside[e];
            // a neighbour two levels coarser, or one whose stitch would break tau here
            const bool stitch_fails =
                view.screenError(box, l.edge_error[at(l, x, y) * 4 + e]) > options_.tau_pixels;
            std::int32_t n = leafLevelAt(p[0], p[1]);
            // the 2:1 restriction always (conformity needs it); a stitch's error only while the
            // cap has room (else the bound reports it)
            while (n > li + 1 || (n == li + 1 && stitch_fails &&
                                  triangles + 3 * kChunkTriangles <= options_.max_triangles)) {
                const Level& nl = levels_[sz(n)];
                const std::int64_t nspan2 = 2 * std::int64_t{K} * nl.step;
                const auto nx = static_cast<std::int32_t>(p[0] / nspan2);
                const auto ny = static_cast<std::int32_t>(p[1] / nspan2);
                split(n, nx, ny);
                ++f.forced_splits;
                triangles += 3 * kChunkTriangles;
                const Level& cl = levels_[sz(n - 1)];
                for (std::int32_t dy = 0; dy < 2; ++dy)
                    for (std::int32_t dx = 0; dx < 2; ++dx)
                        if (2 * nx + dx < cl.nx && 2 * ny + dy < cl.ny)
                            leaves_.push_back({n - 1, 2 * nx + dx, 2 * ny + dy});
                n = leafLevelAt(p[0], p[1]);
            }
            if (n == li + 1 && stitch_fails)
                f.capped = true; // the cap kept a stitch that breaks tau
        }
    }
    // what is drawn, its bound, and what it loads
    if (index_bytes_loaded_ == 0) {
        index_bytes_loaded_ = 16 * kChunkTriangles * kIndexBytes;
        f.upload_bytes += index_bytes_loaded_;
    }
    triangles_ = 0;
    for (const auto& [li, x, y] : leaves_) {
        Level& l = levels_[sz(li)];
        const std::size_t i = at(l, x, y);
        if (l.state[i] != kLeaf || l.visible[i] != 0)
            continue; // split since, or already counted (a leaf is listed once per making)
        ++f.leaves;
        const roam::Box box = boxOf(li, x, y);
        if (!view.intersectsFrustum(box))
            continue;
        l.visible[i] = 1;
        ++f.chunks_drawn;
        const std::array<bool, 4> st = stitching(li, x, y);
        std::int64_t t = kChunkTriangles;
        double error = l.error[i];
        for (std::size_t e = 0; e < 4; ++e)
            if (st[e]) {
                t -= K / 2;
                ++f.stitched_edges;
                error = std::max<double>(error, l.edge_error[i * 4 + e]);
            }
        f.triangles += t;
        const double bound = view.screenError(box, error);
        f.error_bound_pixels = std::max(f.error_bound_pixels, bound);
        if (bound > options_.tau_pixels)
            ++f.chunks_over_tau;
        if (l.loaded[i] == 0 || l.reload[i] != 0)
            f.upload_bytes += std::int64_t{kChunkVertices} * kChunkVertexBytes;
        l.loaded[i] = frame_ + 1;
        l.reload[i] = 0;
    }
    triangles_ = f.triangles;
    // chunks out of the selection long enough give their buffers back
    for (Level& l : levels_)
        for (std::uint64_t& loaded : l.loaded)
            if (loaded != 0 && loaded + options_.evict_after_frames < frame_ + 1)
                loaded = 0;
    return f;
}

template <class Emit>
void ChunkedLod::emitChunk(std::int32_t level, std::int32_t x, std::int32_t y, Emit&& emit) const {
    const std::int32_t s = levels_[sz(level)].step;
    const std::int32_t ox = x * K * s;
    const std::int32_t oy = y * K * s;
    const std::array<bool, 4> st = stitching(level, x, y); // bottom, right, top, left
    const auto g = [&](std::int32_t a, std::int32_t b) {
        return std::array<std::int32_t, 2>{ox + a * s, oy + b * s};
    };
    for (std::int32_t b = 0; b < K; ++b)
        for (std::int32_t a = 0; a < K; ++a) {
            const bool odd = ((a + b) & 1) != 0;
            // the two triangles of the cell, counter-clockwise; each replaced by its merged
            // parent (first of a pair) or dropped (second) where it meets a stitched edge
            std::array<std::array<std::array<std::int32_t, 2>, 3>, 2> tris{};
            std::array<bool, 2> keep = {true, true};
            if (!odd) {
                tris[0] = {g(a, b), g(a + 1, b), g(a + 1, b + 1)}; // lower right
                tris[1] = {g(a, b), g(a + 1, b + 1), g(a, b + 1)}; // upper left
                if (b == 0 && st[0]) // bottom, a even: the first of its pair
                    tris[0] = {g(a, 0), g(a + 2, 0), g(a + 1, 1)};
                if (a == K - 1 && st[1]) // right, b odd: the second
                    keep[0] = false;
                if (a == 0 && st[3]) // left, b even: the first
                    tris[1] = {g(0, b), g(1, b + 1), g(0, b + 2)};
                if (b == K - 1 && st[2]) // top, a odd: the second
                    keep[1] = false;
            } else {
                tris[0] = {g(a, b), g(a + 1, b), g(a, b + 1)};         // lower left
                tris[1] = {g(a + 1, b), g(a + 1, b + 1), g(a, b + 1)}; // upper right
                if (b == 0 && st[0])                                   // bottom, a odd: the second
                    keep[0] = false;
                if (a == 0 && st[3]) // left, b odd: the second
                    keep[0] = false;
                if (a == K - 1 && st[1]) // right, b even: the first
                    tris[1] = {g(K, b), g(K, b + 2), g(K - 1, b + 1)};
                if (b == K - 1 && st[2]) // top, a even: the first
                    tris[1] = {g(a + 2, K), g(a, K), g(a + 1, K - 1)};
            }
            for (int t = 0; t < 2; ++t)
                if (keep[sz(t)])
                    emit(tris[sz(t)]);
        }
}

void ChunkedLod::gridTriangles(
    bool visible_only, std::vector<std::array<std::int32_t, 6>>& out) const {
    out.clear();
    for (std::int32_t li = 0; li < levels(); ++li) {
        const Level& l = levels_[sz(li)];
        for (std::int32_t y = 0; y < l.ny; ++y)
            for (std::int32_t x = 0; x < l.nx; ++x) {
                const std::size_t i = at(l, x, y);
                if (l.state[i] != kLeaf || (visible_only && l.visible[i] == 0))
                    continue;
                emitChunk(li, x, y, [&](const auto& t) {
                    out.push_back({t[0][0], t[0][1], t[1][0], t[1][1], t[2][0], t[2][1]});
                });
            }
    }
}

void ChunkedLod::triangles(bool visible_only, std::vector<glm::dvec3>& out) const {
    out.clear();
    std::vector<std::array<std::int32_t, 6>> grid;
    gridTriangles(visible_only, grid);
    out.reserve(grid.size() * 3);
    for (const auto& t : grid)
        for (int k = 0; k < 3; ++k) {
            const std::int32_t x = t[sz(2 * k)];
            const std::int32_t y = t[sz(2 * k + 1)];
            out.push_back({x * spacing_, y * spacing_, heightAt(x, y)});
        }
}

std::size_t ChunkedLod::memoryBytes() const {
    std::size_t bytes = patch_deviation_.capacity() * sizeof(float) +
                        heap_.capacity() * sizeof(Candidate) +
                        leaves_.capacity() * sizeof(leaves_[0]);
    for (const Level& l : levels_)
        bytes += l.error.capacity() * (3 * sizeof(float) + 3 + sizeof(std::uint64_t));
    return bytes;
}

std::int64_t ChunkedLod::gpuBytes() const {
    std::int64_t bytes = index_bytes_loaded_;
    for (const Level& l : levels_)
        for (std::uint64_t loaded : l.loaded)
            if (loaded != 0)
                bytes += std::int64_t{kChunkVertices} * kChunkVertexBytes;
    return bytes;
}

} // namespace terrain::lodlab
