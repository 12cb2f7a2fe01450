#pragma once

// What a battle did to a terrain, measured against the ground before it: how high any point ever
// stood above the highest original ground near it, needles, the steepest slope, how deep it dug,
// where the patches are. Shared by the stability suite (which asserts bounds) and battle_bench
// (which reports them).

#include <terrain/battle.h>
#include <terrain/deform_op.h>
#include <terrain/detail_patch.h>
#include <terrain/terrain.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <utility>
#include <vector>

namespace terrain::testing {

struct BattleFigures {
    int shots = 0;
    int craters = 0; ///< accepted ops
    int missed = 0;  ///< rays that met no ground
    int refused = 0; ///< requests quantizeOp or apply refused
    /// The highest any base vertex ever stood above the highest original ground within the
    /// reach (the largest footprint) around it, and above its own original height.
    double max_rise_m = 0.0;
    double max_rise_own_m = 0.0;
    /// The same for the final patch surfaces (17 x 17 grids) against the ground around the cell.
    double max_patch_rise_m = 0.0;
    double deepest_m = 0.0;        ///< most any vertex lies below its original height
    int needles = 0;               ///< vertices more than the needle height above all 8 neighbours
    double tallest_spike_m = 0.0;  ///< the most any vertex stands above all 8 neighbours
    double max_slope = 0.0;        ///< steepest rise over run between 8-neighbours (changed ground)
    double max_slope_before = 0.0; ///< the same ground before the battle
    std::size_t patches = 0;
    double patch_extent_m = 0.0; ///< farthest patched cell centre from the zone centre
    std::size_t changed_vertices = 0;
    struct Spot {
        std::int32_t x = 0;
        std::int32_t y = 0;
        double value = 0.0;
    };
    std::vector<Spot> needle_spots; ///< the first few needles, for a person to look at
    Spot steepest;                  ///< where the steepest slope is
};

class BattleWatch {
  public:
    /// `reach_metres`: the largest footprint radius of the battle's craters.
    BattleWatch(const Terrain& t, double reach_metres)
        : spec_(t.spec()), initial_(t.paddedSamples().begin(), t.paddedSamples().end()),
          highest_(initial_),
          window_(static_cast<std::int32_t>(std::ceil(reach_metres / spec_.spacingMetres()))) {}

    /// After every op: the vertices it may have changed.
    void observe(const Terrain& t, const OpEffect& e) {
        for (std::int32_t y = e.vertices.y0; y <= e.vertices.y1; ++y)
            for (std::int32_t x = e.vertices.x0; x <= e.vertices.x1; ++x) {
                std::int32_t& h = highest_[index(x, y)];
                h = std::max(h, t.sample(x, y));
            }
    }

    /// Every vertex at once (for a world whose history is not at hand, such as a journal's end).
    void observeAll(const Terrain& t) {
        observe(t, OpEffect{CellRect{0, 0, spec_.width - 1, spec_.height - 1}, {}, {}, 0, 0, 0, 0});
    }

    BattleFigures
    figures(const Terrain& t, double needle_height_m, double zone_x, double zone_y) const {
        BattleFigures f;
        const double m = spec_.metresPerUnit();
        const double h = spec_.spacingMetres();
        const std::int32_t w = spec_.width;
        const std::int32_t hh = spec_.height;
        auto now = [&](std::int32_t x, std::int32_t y) { return t.sample(x, y); };
        auto before = [&](std::int32_t x, std::int32_t y) { return initial_[index(x, y)]; };
        auto slopeAt = [&](auto height, std::int32_t x, std::int32_t y) {
            double worst = 0.0;
            for (int dy = -1; dy <= 1; ++dy)
                for (int dx = -1; dx <= 1; ++dx) {
                    const std::int32_t nx = x + dx;
                    const std::int32_t ny = y + dy;
                    if ((dx == 0 && dy == 0) || nx < 0 || ny < 0 || nx >= w || ny >= hh)
                        continue;
                    const double run = h * std::sqrt(static_cast<double>(dx * dx + dy * dy));
                    worst = std::max(
                        worst,
                        std::abs(static_cast<double>(height(x, y) - height(nx, ny))) * m / run);
                }
            return worst;
        };
        for (std::int32_t y = 0; y < hh; ++y)
            for (std::int32_t x = 0; x < w; ++x) {
                const std::int32_t z0 = before(x, y);
                const std::int32_t z = now(x, y);
                const std::int32_t top = highest_[index(x, y)];
                if (z == z0 && top == z0)
                    continue;
                ++f.changed_vertices;
                f.max_rise_own_m = std::max(f.max_rise_own_m, (top - z0) * m);
                f.max_rise_m = std::max(f.max_rise_m, (top - localMax(x, y)) * m);
                f.deepest_m = std::max(f.deepest_m, (z0 - z) * m);
                std::int32_t around = INT32_MIN;
                for (int dy = -1; dy <= 1; ++dy)
                    for (int dx = -1; dx <= 1; ++dx) {
                        const std::int32_t nx = x + dx;
                        const std::int32_t ny = y + dy;
                        if ((dx != 0 || dy != 0) && nx >= 0 && ny >= 0 && nx < w && ny < hh)
                            around = std::max(around, now(nx, ny));
                    }
                const double spike = (z - around) * m;
                f.tallest_spike_m = std::max(f.tallest_spike_m, spike);
                if (spike > needle_height_m && ++f.needles <= 10)
                    f.needle_spots.push_back({x, y, spike});
                if (const double s = slopeAt(now, x, y); s > f.max_slope) {
                    f.max_slope = s;
                    f.steepest = {x, y, s};
                }
                f.max_slope_before = std::max(f.max_slope_before, slopeAt(before, x, y));
            }
        std::array<std::int32_t, kPatchGridVertices> grid{};
        for (std::int32_t tile = 0; tile < spec_.tileCount(); ++tile)
            for (const PatchEntry& e : t.tilePatches(tile)) {
                ++f.patches;
                const std::int32_t cx = (tile % spec_.tilesX()) * kTileCells + e.cell % kTileCells;
                const std::int32_t cy = (tile / spec_.tilesX()) * kTileCells + e.cell / kTileCells;
                f.patch_extent_m = std::max(
                    f.patch_extent_m, std::hypot((cx + 0.5) * h - zone_x, (cy + 0.5) * h - zone_y));
                evaluateGrid(e.patch, grid);
                const std::int32_t ground = std::max(
                    std::max(localMax(cx, cy), localMax(cx + 1, cy)),
                    std::max(localMax(cx, cy + 1), localMax(cx + 1, cy + 1)));
                const std::int32_t top = *std::max_element(grid.begin(), grid.end());
                f.max_patch_rise_m = std::max(f.max_patch_rise_m, (top - ground) * m);
            }
        return f;
    }

  private:
    std::size_t index(std::int32_t x, std::int32_t y) const {
        return static_cast<std::size_t>(y) * static_cast<std::size_t>(spec_.paddedWidth()) +
               static_cast<std::size_t>(x);
    }
    // the highest original ground within the window around (x, y)
    std::int32_t localMax(std::int32_t x, std::int32_t y) const {
        std::int32_t top = INT32_MIN;
        for (std::int32_t ny = std::max(0, y - window_);
             ny <= std::min(spec_.height - 1, y + window_); ++ny)
            for (std::int32_t nx = std::max(0, x - window_);
                 nx <= std::min(spec_.width - 1, x + window_); ++nx)
                top = std::max(top, initial_[index(nx, ny)]);
        return top;
    }

    WorldSpec spec_;
    std::vector<std::int32_t> initial_;
    std::vector<std::int32_t> highest_;
    std::int32_t window_ = 0;
};

/// Runs `shots` shots of `generator` on `t`, applying each accepted crater; `watch` sees every
/// op, and `applied` (when given) records each with the world hash after it. Returns the counts
/// (figures() fills the rest).
inline BattleFigures runBattle(
    Terrain& t,
    BattleGenerator& generator,
    int shots,
    BattleWatch& watch,
    std::vector<std::pair<DeformOp, std::uint64_t>>* applied = nullptr) {
    BattleFigures f;
    for (int i = 0; i < shots; ++i) {
        const BattleShot shot = generator.next(t);
        ++f.shots;
        if (!shot.crater) {
            ++f.missed;
            continue;
        }
        auto op = quantizeOp(*shot.crater, t.spec());
        if (!op) {
            ++f.refused;
            continue;
        }
        auto effect = t.apply(*op);
        if (!effect) {
            ++f.refused;
            continue;
        }
        ++f.craters;
        if (applied != nullptr)
            applied->emplace_back(*op, t.worldHash());
        watch.observe(t, *effect);
    }
    return f;
}

} // namespace terrain::testing
