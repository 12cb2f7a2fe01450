// Surface queries. Ray traversal: Amanatides & Woo, "A Fast Voxel Traversal Algorithm for Ray
// Tracing" (1987), in 2D over cells; triangle test: Moller & Trumbore (1997).
// Every loop is bounded: the DDA moves one cell per step and stops at the map edge, the patch
// search takes a fixed number of samples and halvings.

#include <terrain/base_cell.h>
#include <terrain/detail_patch.h>
#include <terrain/surface_query.h>

#include <glm/geometric.hpp>

#include <algorithm>
#include <cmath>
#include <limits>

namespace terrain {
namespace {

struct CellPoint {
    std::int32_t cx = 0;
    std::int32_t cy = 0;
    double u = 0.0;
    double v = 0.0;
};

CellPoint locate(const WorldSpec& spec, double x, double y) {
    const double h = spec.spacingMetres();
    const double gx = std::clamp(x / h, 0.0, static_cast<double>(spec.cellsX()));
    const double gy = std::clamp(y / h, 0.0, static_cast<double>(spec.cellsY()));
    CellPoint p;
    p.cx = std::min(static_cast<std::int32_t>(gx), spec.cellsX() - 1);
    p.cy = std::min(static_cast<std::int32_t>(gy), spec.cellsY() - 1);
    p.u = gx - p.cx;
    p.v = gy - p.cy;
    return p;
}

// height in quanta at (u, v) of a cell
double cellHeight(const Terrain& t, std::int32_t cx, std::int32_t cy, double u, double v) {
    if (const DetailPatch* p = t.findPatch(cx, cy))
        return patchHeight(*p, u, v);
    return baseHeight(t.corners(cx, cy), cellDiagonal(cx, cy), u, v);
}

glm::dvec3 normalFromGradient(const Terrain& t, const Gradient& g) {
    // quanta per unit parameter -> metres per metre
    const double scale = t.spec().metresPerUnit() / t.spec().spacingMetres();
    return glm::normalize(glm::dvec3(-g.du * scale, -g.dv * scale, 1.0));
}

glm::dvec3 cellNormal(const Terrain& t, std::int32_t cx, std::int32_t cy, double u, double v) {
    if (const DetailPatch* p = t.findPatch(cx, cy))
        return normalFromGradient(t, patchGradient(*p, u, v));
    return normalFromGradient(t, baseGradient(t.corners(cx, cy), cellDiagonal(cx, cy), u, v));
}

std::optional<double> rayTriangle(
    const glm::dvec3& o,
    const glm::dvec3& d,
    const glm::dvec3& a,
    const glm::dvec3& b,
    const glm::dvec3& c) {
    const glm::dvec3 e1 = b - a;
    const glm::dvec3 e2 = c - a;
    const glm::dvec3 p = glm::cross(d, e2);
    const double det = glm::dot(e1, p);
    if (std::abs(det) < 1e-300)
        return std::nullopt;
    const double inv = 1.0 / det;
    const glm::dvec3 s = o - a;
    const double bu = glm::dot(s, p) * inv;
    constexpr double kEdge = 1e-12; // closes hairline gaps on shared triangle edges
    if (bu < -kEdge || bu > 1.0 + kEdge)
        return std::nullopt;
    const glm::dvec3 q = glm::cross(s, e1);
    const double bv = glm::dot(d, q) * inv;
    if (bv < -kEdge || bu + bv > 1.0 + kEdge)
        return std::nullopt;
    return glm::dot(e2, q) * inv;
}

} // namespace

double surfaceHeight(const Terrain& t, double x, double y) {
    if (std::isnan(x) || std::isnan(y))
        return std::numeric_limits<double>::quiet_NaN();
    const CellPoint p = locate(t.spec(), x, y);
    return cellHeight(t, p.cx, p.cy, p.u, p.v) * t.spec().metresPerUnit();
}

glm::dvec3 surfaceNormal(const Terrain& t, double x, double y) {
    if (std::isnan(x) || std::isnan(y))
        return glm::dvec3(std::numeric_limits<double>::quiet_NaN());
    const CellPoint p = locate(t.spec(), x, y);
    return cellNormal(t, p.cx, p.cy, p.u, p.v);
}

std::optional<RayHit> castRay(
    const Terrain& t, const glm::dvec3& origin, const glm::dvec3& direction, double max_distance) {
    const WorldSpec& spec = t.spec();
    if (!std::isfinite(origin.x) || !std::isfinite(origin.y) || !std::isfinite(origin.z) ||
        !std::isfinite(direction.x) || !std::isfinite(direction.y) || !std::isfinite(direction.z) ||
        !std::isfinite(max_distance) || max_distance <= 0.0)
        return std::nullopt;
    // |direction|^2 must be finite and non-zero, or distances and the bisection degenerate
    const double length2 = glm::dot(direction, direction);
    if (!(length2 > 0.0) || !std::isfinite(length2))
        return std::nullopt;
    const double h = spec.spacingMetres();
    const double q = spec.metresPerUnit();

    // clip to the map's xy box (slab test)
    double s0 = 0.0;
    double s1 = max_distance;
    const double lo[2] = {0.0, 0.0};
    const double hi[2] = {spec.extentX(), spec.extentY()};
    const double o2[2] = {origin.x, origin.y};
    const double d2[2] = {direction.x, direction.y};
    for (int axis = 0; axis < 2; ++axis) {
        if (d2[axis] == 0.0) {
            if (o2[axis] < lo[axis] || o2[axis] > hi[axis])
                return std::nullopt;
            continue;
        }
        double a = (lo[axis] - o2[axis]) / d2[axis];
        double b = (hi[axis] - o2[axis]) / d2[axis];
        if (a > b)
            std::swap(a, b);
        s0 = std::max(s0, a);
        s1 = std::min(s1, b);
    }
    if (s0 > s1)
        return std::nullopt;

    auto at = [&](double s) { return origin + s * direction; };
    const glm::dvec3 entry = at(s0);
    // clamp in double before the cast: a far origin must not overflow the int conversion
    auto cellIndex = [](double g, std::int32_t cells) {
        return static_cast<std::int32_t>(
            std::clamp(std::floor(g), 0.0, static_cast<double>(cells - 1)));
    };
    std::int32_t cx = cellIndex(entry.x / h, spec.cellsX());
    std::int32_t cy = cellIndex(entry.y / h, spec.cellsY());
    const std::int32_t step_x = direction.x > 0 ? 1 : -1;
    const std::int32_t step_y = direction.y > 0 ? 1 : -1;
    const double inf = std::numeric_limits<double>::infinity();
    const double delta_x = direction.x != 0.0 ? h / std::abs(direction.x) : inf;
    const double delta_y = direction.y != 0.0 ? h / std::abs(direction.y) : inf;
    double next_x =
        direction.x != 0.0 ? ((cx + (step_x > 0 ? 1 : 0)) * h - origin.x) / direction.x : inf;
    double next_y =
        direction.y != 0.0 ? ((cy + (step_y > 0 ? 1 : 0)) * h - origin.y) / direction.y : inf;

    double cell_s0 = s0;
    while (true) {
        const double cell_s1 = std::min({next_x, next_y, s1});
        // z range of the ray over this cell against the cell's height range
        const double za = at(cell_s0).z;
        const double zb = at(cell_s1).z;
        const DetailPatch* patch = t.findPatch(cx, cy);
        const CellCorners c = t.corners(cx, cy);
        double zmin = 0.0;
        double zmax = 0.0;
        if (patch != nullptr) {
            const HeightRange r = controlRange(*patch);
            zmin = r.min * q;
            zmax = r.max * q;
        } else {
            zmin = std::min({c.h00, c.h10, c.h01, c.h11}) * q;
            zmax = std::max({c.h00, c.h10, c.h01, c.h11}) * q;
        }
        if (std::min(za, zb) <= zmax && std::max(za, zb) >= zmin) {
            std::optional<double> hit;
            if (patch == nullptr) {
                const double x0 = cx * h;
                const double y0 = cy * h;
                const glm::dvec3 p00(x0, y0, c.h00 * q);
                const glm::dvec3 p10(x0 + h, y0, c.h10 * q);
                const glm::dvec3 p01(x0, y0 + h, c.h01 * q);
                const glm::dvec3 p11(x0 + h, y0 + h, c.h11 * q);
                std::optional<double> ta;
                std::optional<double> tb;
                if (cellDiagonal(cx, cy) == Diagonal::kMain) {
                    ta = rayTriangle(origin, direction, p00, p10, p11);
                    tb = rayTriangle(origin, direction, p00, p11, p01);
                } else {
                    ta = rayTriangle(origin, direction, p00, p10, p01);
                    tb = rayTriangle(origin, direction, p10, p11, p01);
                }
                const double slack = 1e-9 * (cell_s1 - cell_s0 + 1.0);
                for (const auto& cand : {ta, tb})
                    if (cand && *cand >= cell_s0 - slack && *cand <= cell_s1 + slack &&
                        (!hit || *cand < *hit))
                        hit = std::max(*cand, cell_s0);
            } else {
                // f(s) = ray z - surface z; the patch is cubic per knot span, so split the
                // segment where it crosses u = 1/2 or v = 1/2, then sample each piece finely
                auto f = [&](double s) {
                    const glm::dvec3 p = at(s);
                    const double u = std::clamp(p.x / h - cx, 0.0, 1.0);
                    const double v = std::clamp(p.y / h - cy, 0.0, 1.0);
                    return p.z - patchHeight(*patch, u, v) * q;
                };
                double cuts[4] = {cell_s0, cell_s1, cell_s1, cell_s1};
                int ncuts = 1;
                if (direction.x != 0.0) {
                    const double s = ((cx + 0.5) * h - origin.x) / direction.x;
                    if (s > cell_s0 && s < cell_s1)
                        cuts[ncuts++] = s;
                }
                if (direction.y != 0.0) {
                    const double s = ((cy + 0.5) * h - origin.y) / direction.y;
                    if (s > cell_s0 && s < cell_s1)
                        cuts[ncuts++] = s;
                }
                cuts[ncuts++] = cell_s1;
                std::sort(cuts, cuts + ncuts);
                constexpr int kSteps = 24;
                for (int piece = 0; piece + 1 < ncuts && !hit; ++piece) {
                    double a = cuts[piece];
                    double fa = f(a);
                    if (fa <= 0.0) {
                        hit = a;
                        break;
                    }
                    for (int k = 1; k <= kSteps; ++k) {
                        const double b = cuts[piece] + (cuts[piece + 1] - cuts[piece]) * k / kSteps;
                        const double fb = f(b);
                        if (fb <= 0.0) {
                            // bisect the bracket [a, b]
                            double lo_s = a;
                            double hi_s = b;
                            // a fixed count, not a width test: far from the origin, adjacent
                            // doubles can be wider than any tolerance
                            for (int i = 0; i < 64; ++i) {
                                const double mid = 0.5 * (lo_s + hi_s);
                                if (mid <= lo_s || mid >= hi_s)
                                    break;
                                (f(mid) > 0.0 ? lo_s : hi_s) = mid;
                            }
                            hit = hi_s;
                            break;
                        }
                        a = b;
                        fa = fb;
                    }
                }
            }
            if (hit) {
                RayHit r;
                r.distance = *hit;
                r.point = at(*hit);
                r.cell_x = cx;
                r.cell_y = cy;
                const double u = std::clamp(r.point.x / h - cx, 0.0, 1.0);
                const double v = std::clamp(r.point.y / h - cy, 0.0, 1.0);
                r.normal = cellNormal(t, cx, cy, u, v);
                return r;
            }
        }
        if (cell_s1 >= s1)
            return std::nullopt;
        if (next_x < next_y) {
            cx += step_x;
            cell_s0 = next_x;
            next_x += delta_x;
        } else {
            cy += step_y;
            cell_s0 = next_y;
            next_y += delta_y;
        }
        if (cx < 0 || cy < 0 || cx >= spec.cellsX() || cy >= spec.cellsY())
            return std::nullopt;
    }
}

} // namespace terrain
