// libFuzzer target: genesis delta decoding (untrusted bytes from the network), on a genesis.
// Property: never crash; anything that decodes satisfies every invariant and re-encodes to the
// very same bytes (the format has one encoding per world). Modes (first input byte): raw input,
// byte patches of a valid delta with the checksum fixed up (to reach the deep checks),
// truncation of a valid delta.

#include "mutated_input.h"

#include <terrain/genesis_delta.h>
#include <terrain/op_script.h>
#include <terrain/procedural_map.h>

#include <cstdint>
#include <cstdlib>
#include <optional>
#include <vector>

namespace {

std::optional<terrain::Terrain> g_genesis;
std::vector<std::uint8_t> g_valid;
} // namespace

extern "C" int LLVMFuzzerInitialize(int*, char***) {
    terrain::ProceduralMapOptions o;
    o.width = 140; // three tiles by two, one of them left as created
    o.height = 70;
    o.seed = 3;
    g_genesis = std::move(*terrain::makeProceduralMap(o));
    terrain::Terrain t = *g_genesis;
    terrain::CraterSeries s;
    s.count = 12;
    s.max_radius = 6.0;
    for (const auto& r : terrain::randomCraters(t.spec(), s))
        if (r.x < 90.0)
            (void)t.apply(*terrain::quantizeOp(r, t.spec()));
    g_valid = terrain::encodeGenesisDelta(t, 42, t.genesisHash());
    return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    const std::vector<std::uint8_t> input = terrain::fuzz::mutatedInput(data, size, g_valid);
    auto decoded = terrain::decodeGenesisDelta(input, *g_genesis);
    if (!decoded)
        return 0;
    if (!decoded->terrain.checkInvariants().ok())
        std::abort();
    if (terrain::encodeGenesisDelta(
            decoded->terrain, decoded->sequence, decoded->terrain.genesisHash()) != input)
        std::abort();
    return 0;
}
