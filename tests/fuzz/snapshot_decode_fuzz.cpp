// libFuzzer target: snapshot decoding (untrusted bytes from disk or the network).
// Property: never crash; anything that decodes satisfies every invariant and re-encodes to the
// very same bytes. Modes (first input byte): raw input, byte patches of a valid snapshot with the
// checksum fixed up (to reach the deep checks), truncation of a valid snapshot.

#include "mutated_input.h"

#include <terrain/op_script.h>
#include <terrain/procedural_map.h>
#include <terrain/snapshot.h>

#include <cstdint>
#include <cstdlib>
#include <vector>

namespace {

std::vector<std::uint8_t> g_valid;
} // namespace

extern "C" int LLVMFuzzerInitialize(int*, char***) {
    terrain::ProceduralMapOptions o;
    o.width = 100;
    o.height = 70;
    o.seed = 3;
    auto t = terrain::makeProceduralMap(o);
    terrain::CraterSeries s;
    s.count = 12;
    for (const auto& r : terrain::randomCraters(t->spec(), s))
        (void)t->apply(*terrain::quantizeOp(r, t->spec()));
    g_valid = terrain::encodeSnapshot(*t, 42);
    return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    const std::vector<std::uint8_t> input = terrain::fuzz::mutatedInput(data, size, g_valid);
    auto decoded = terrain::decodeSnapshot(input);
    if (!decoded)
        return 0;
    if (!decoded->terrain.checkInvariants().ok())
        std::abort();
    if (terrain::encodeSnapshot(decoded->terrain, decoded->sequence) != input)
        std::abort();
    return 0;
}
