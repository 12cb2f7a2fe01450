#pragma once

// Where a tessellator's memory goes, for the benchmarks' JSON reports and their printed lines
// (client_battle_bench, client_join_bench): the same breakdown in both.

#include "support/bench_facts.h"

#include <terrain/roam/tessellator.h>

#include <nlohmann/json.hpp>

#include <cstdio>

namespace terrain::bench {

inline nlohmann::ordered_json tessellatorMemoryJson(const roam::Tessellator& tess) {
    const roam::TessellatorMemory m = tess.memory();
    const auto grains = tess.grainCounts();
    return {
        {"total", mib(m.total())},
        {"grid", mib(m.grid)},
        {"records", mib(m.records)},
        {"grains", {mib(m.grains[0]), mib(m.grains[1]), mib(m.grains[2])}},
        {"grain_chunks", {grains[0], grains[1], grains[2]}},
        {"heap", mib(m.heap)},
        {"meshes", mib(m.meshes)},
        {"scratch", mib(m.scratch)}};
}

inline void printTessellatorMemory(const roam::Tessellator& tess) {
    const roam::TessellatorMemory m = tess.memory();
    const auto grains = tess.grainCounts();
    std::printf(
        "  tessellator MiB: grid %.1f, records %.1f, grains %.1f / %.1f / %.1f (%d / %d / %d "
        "chunks), heap %.1f, meshes %.1f, scratch %.1f\n",
        mib(m.grid), mib(m.records), mib(m.grains[0]), mib(m.grains[1]), mib(m.grains[2]),
        grains[0], grains[1], grains[2], mib(m.heap), mib(m.meshes), mib(m.scratch));
}

} // namespace terrain::bench
