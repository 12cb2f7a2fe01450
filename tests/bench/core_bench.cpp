// Core timings (Google Benchmark; --benchmark_out=FILE --benchmark_out_format=json for JSON):
//  - crater apply time by radius on a 1 m grid, with patches (tolerance 1/32 m) and without
//    (tolerance 1 km: the grid holds everything, the patch test still runs);
//  - crater apply on the SRTM tile (66 m grid) by radius;
//  - tile hash, world hash combine, full rehash; snapshot encode and decode;
//  - DEM import of srtm_n44w072.

#include <terrain/io/dem_import.h>
#include <terrain/journal/journal.h>
#include <terrain/procedural_map.h>
#include <terrain/snapshot.h>
#include <terrain/terrain.h>

#include <benchmark/benchmark.h>

#include <filesystem>
#include <optional>

namespace terrain {
namespace {

const std::filesystem::path kSrtm = std::filesystem::path(TERRAIN_DEM_DIR) / "srtm_n44w072";

Terrain benchMap(double tolerance_m) {
    ProceduralMapOptions o;
    o.seed = 3;
    o.width = 2049;
    o.height = 2049;
    o.patch_tolerance_metres = tolerance_m;
    return std::move(*makeProceduralMap(o));
}

// Craters on a lattice of sites far enough apart that each lands on fresh ground until the
// lattice wraps (small radii never wrap within a benchmark run).
void runCraters(benchmark::State& state, Terrain& t, double radius) {
    const WorldSpec& spec = t.spec();
    const double step = 4.0 * radius + 4.0 * spec.spacingMetres();
    const int per_row = std::max(1, static_cast<int>((spec.extentX() - step) / step));
    const int sites = per_row * std::max(1, static_cast<int>((spec.extentY() - step) / step));
    std::int64_t created = 0;
    std::int64_t cells = 0;
    int i = 0;
    for (auto _ : state) {
        const int site = i++ % sites;
        OpRequest r{
            OpKind::kCrater,
            step * (1 + site % per_row) + 0.37,
            step * (1 + site / per_row) + 0.61,
            radius,
            0.4 * radius,
            0.25};
        auto effect = t.apply(*quantizeOp(r, spec));
        created += effect->patches_created;
        cells +=
            (effect->cells.x1 - effect->cells.x0 + 1) * (effect->cells.y1 - effect->cells.y0 + 1);
        benchmark::DoNotOptimize(t.worldHash());
    }
    state.counters["patches_per_op"] =
        benchmark::Counter(static_cast<double>(created) / static_cast<double>(state.iterations()));
    state.counters["cells_per_op"] =
        benchmark::Counter(static_cast<double>(cells) / static_cast<double>(state.iterations()));
    state.counters["radius_m"] = radius;
}

void BM_CraterApply(benchmark::State& state) {
    const double radius = static_cast<double>(state.range(0));
    const bool patches = state.range(1) != 0;
    Terrain t = benchMap(patches ? 1.0 / 32.0 : 1000.0);
    runCraters(state, t, radius);
    state.SetLabel(patches ? "patches tol=1/32m" : "grid only");
}
BENCHMARK(BM_CraterApply)
    ->ArgsProduct({{1, 2, 4, 8, 16, 32}, {1, 0}})
    ->ArgNames({"radius_m", "patches"})
    ->Unit(benchmark::kMicrosecond);

void BM_CraterApplySrtm(benchmark::State& state) {
    if (!std::filesystem::exists(kSrtm)) {
        state.SkipWithError("srtm_n44w072 absent (../shared/data/dem)");
        return;
    }
    auto dem = io::importDem(kSrtm, {});
    runCraters(state, dem->terrain, static_cast<double>(state.range(0)));
}
BENCHMARK(BM_CraterApplySrtm)
    ->Arg(100)
    ->Arg(400)
    ->Arg(1600)
    ->ArgName("radius_m")
    ->Unit(benchmark::kMicrosecond);

void BM_TileHash(benchmark::State& state) {
    Terrain t = benchMap(1.0 / 32.0);
    for (auto _ : state)
        benchmark::DoNotOptimize(t.computeTileHash(17));
    state.SetBytesProcessed(state.iterations() * kTileVertices * kTileVertices * 4);
}
BENCHMARK(BM_TileHash)->Unit(benchmark::kMicrosecond);

void BM_FullRehash(benchmark::State& state) {
    Terrain t = benchMap(1.0 / 32.0);
    for (auto _ : state)
        benchmark::DoNotOptimize(t.computeWorldHash());
    state.counters["tiles"] = t.spec().tileCount();
}
BENCHMARK(BM_FullRehash)->Unit(benchmark::kMillisecond);

// the incremental path: one small crater dirties 1-4 tiles; compare with BM_CraterApply
void BM_SnapshotEncode(benchmark::State& state) {
    Terrain t = benchMap(1.0 / 32.0);
    for (auto _ : state)
        benchmark::DoNotOptimize(encodeSnapshot(t, 0));
    state.counters["bytes"] = static_cast<double>(encodeSnapshot(t, 0).size());
}
BENCHMARK(BM_SnapshotEncode)->Unit(benchmark::kMillisecond);

// the bench map after 1,000 craters of 6 m spread over it (about 200,000 patches): a battle's
// world for the copy and snapshot benchmarks
Terrain battleWorld() {
    Terrain t = benchMap(1.0 / 32.0);
    for (int i = 0; i < 1000; ++i)
        (void)t.apply(*quantizeOp(
            OpRequest{
                OpKind::kCrater, 40.0 + (i % 40) * 49.0, 40.0 + (i / 40) * 49.0 + (i % 7), 6.0, 2.4,
                0.25},
            t.spec()));
    return t;
}

// what a journal or join snapshot costs the server's io thread: the copy it hands to the
// snapshot thread (a 1,000-crater world, the patches included)
void BM_TerrainCopy(benchmark::State& state) {
    Terrain t = battleWorld();
    for (auto _ : state) {
        Terrain copy = t;
        benchmark::DoNotOptimize(copy.worldHash());
    }
    state.counters["patches"] = static_cast<double>(t.patchCount());
}
BENCHMARK(BM_TerrainCopy)->Unit(benchmark::kMillisecond);

// What a journal snapshot costs its io thread: bringing the copy it keeps up to date after one
// more crater, by assignment (arg 0) or by syncFrom (arg 1: the changed tiles only)
void BM_SnapshotCopyFollows(benchmark::State& state) {
    Terrain t = battleWorld();
    Terrain copy = t;
    const bool sync = state.range(0) == 1;
    int i = 0;
    std::size_t tiles = 0;
    for (auto _ : state) {
        state.PauseTiming();
        (void)t.apply(*quantizeOp(
            OpRequest{
                OpKind::kCrater, 60.0 + (i % 30) * 61.0, 900.0 + (i % 11) * 3.0, 5.0, 2.0, 0.25},
            t.spec()));
        ++i;
        state.ResumeTiming();
        if (sync)
            tiles += copy.syncFrom(t);
        else
            copy = t;
        benchmark::DoNotOptimize(copy.worldHash());
    }
    state.counters["patches"] = static_cast<double>(t.patchCount());
    state.counters["tiles_copied"] =
        sync ? static_cast<double>(tiles) / static_cast<double>(state.iterations())
             : static_cast<double>(t.spec().tileCount());
}
BENCHMARK(BM_SnapshotCopyFollows)->Arg(0)->Arg(1)->Unit(benchmark::kMicrosecond);

// What a journal snapshot costs the snapshot thread on a battle's world: the encode alone
// (arg 0), and the file written and made durable as the journal does (arg 1)
void BM_SnapshotWrite(benchmark::State& state) {
    Terrain t = battleWorld();
    const auto dir = std::filesystem::temp_directory_path() / "core_bench_snapshot";
    std::filesystem::create_directories(dir);
    std::size_t bytes = 0;
    for (auto _ : state) {
        if (state.range(0) == 0) {
            const auto encoded = encodeSnapshot(t, 1);
            bytes = encoded.size();
        } else if (!journal::writeSnapshotFile(dir, t, 1)) {
            state.SkipWithError("writeSnapshotFile failed");
        }
    }
    std::filesystem::remove_all(dir);
    state.counters["patches"] = static_cast<double>(t.patchCount());
    if (bytes != 0)
        state.counters["MB"] = static_cast<double>(bytes) / 1e6;
}
BENCHMARK(BM_SnapshotWrite)->Arg(0)->Arg(1)->Unit(benchmark::kMillisecond);

void BM_SnapshotDecode(benchmark::State& state) {
    const auto bytes = encodeSnapshot(benchMap(1.0 / 32.0), 0);
    for (auto _ : state)
        benchmark::DoNotOptimize(decodeSnapshot(bytes));
}
BENCHMARK(BM_SnapshotDecode)->Unit(benchmark::kMillisecond);

void BM_ImportSrtm(benchmark::State& state) {
    if (!std::filesystem::exists(kSrtm)) {
        state.SkipWithError("srtm_n44w072 absent (../shared/data/dem)");
        return;
    }
    for (auto _ : state)
        benchmark::DoNotOptimize(io::importDem(kSrtm, {}));
    state.SetBytesProcessed(state.iterations() * 1201 * 1201 * 2);
}
BENCHMARK(BM_ImportSrtm)->Unit(benchmark::kMillisecond);

} // namespace
} // namespace terrain

BENCHMARK_MAIN();
