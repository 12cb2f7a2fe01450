// The tessellator's kernels alone (Google Benchmark; --benchmark_out=FILE
// --benchmark_out_format=json for JSON), on the worlds its tests use, without the noise of a
// whole battle frame around them:
//  - BlockBounds::compute, the re-bound of a square of detail blocks after a crater (a 16 x 16
//    square, as BoundsUpdate passes them): time per block (`us_per_block`).

#include <terrain/op_script.h>
#include <terrain/procedural_map.h>
#include <terrain/roam/block_bounds.h>
#include <terrain/roam/detail_blocks.h>
#include <terrain/terrain.h>

#include <benchmark/benchmark.h>

#include <cstdio>
#include <cstdlib>
#include <vector>

namespace terrain {
namespace {

/// The bounds tests' world: hills 150 x 140 at 1 m, 60 craters (seed 7).
Terrain crateredHills() {
    ProceduralMapOptions o;
    o.seed = 7;
    o.width = 150;
    o.height = 140;
    o.spacing_metres = 1.0;
    o.amplitude_metres = 12.0;
    o.wavelength_metres = 64.0;
    o.octaves = 4;
    auto t = makeProceduralMap(o);
    if (!t.ok()) {
        std::fprintf(stderr, "roam_kernel_bench: no map: %s\n", t.error().message.c_str());
        std::exit(2);
    }
    CraterSeries s;
    s.seed = 7;
    s.count = 60;
    for (const OpRequest& r : randomCraters(t->spec(), s)) {
        auto op = quantizeOp(r, t->spec());
        if (!op.ok() || !t->apply(*op).ok()) {
            std::fprintf(stderr, "roam_kernel_bench: a crater was refused\n");
            std::exit(2);
        }
    }
    return std::move(*t);
}

void BM_BlockBoundsSquare(benchmark::State& state) {
    const Terrain t = crateredHills();
    roam::DetailBlocks records;
    records.reset(t);
    // the 16 x 16 square of cells (aligned, as a pass's) holding the most detail cells
    constexpr std::int32_t kSquare = 16;
    std::vector<roam::DetailBlocks::CellXY> best;
    for (std::int32_t sy = 0; sy < records.cellsY(); sy += kSquare)
        for (std::int32_t sx = 0; sx < records.cellsX(); sx += kSquare) {
            std::vector<roam::DetailBlocks::CellXY> cells;
            for (std::int32_t y = sy; y < std::min(sy + kSquare, records.cellsY()); ++y)
                for (std::int32_t x = sx; x < std::min(sx + kSquare, records.cellsX()); ++x)
                    if (records.recordOf(x, y) >= 0)
                        cells.push_back({x, y});
            if (cells.size() > best.size())
                best = std::move(cells);
        }
    const WorldSpec& spec = t.spec();
    const roam::BlockGeometry g{
        spec.metresPerUnit() / static_cast<double>(roam::kFineUnitsPerQuantum), spec.paddedWidth(),
        spec.paddedHeight(), spec.cellsX(), spec.cellsY()};
    roam::BlockBounds kernel;
    for (auto _ : state) {
        kernel.compute(t, records, g, best);
        benchmark::DoNotOptimize(kernel.bounds(0, 1));
    }
    state.counters["blocks"] = static_cast<double>(best.size());
    state.counters["us_per_block"] = benchmark::Counter(
        static_cast<double>(best.size()) * 1e-6,
        benchmark::Counter::kIsIterationInvariantRate | benchmark::Counter::kInvert);
}
BENCHMARK(BM_BlockBoundsSquare)->Unit(benchmark::kMicrosecond);

} // namespace
} // namespace terrain

BENCHMARK_MAIN();
