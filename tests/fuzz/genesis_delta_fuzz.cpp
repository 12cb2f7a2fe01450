// libFuzzer target: genesis delta decoding (untrusted bytes from the network), on a genesis.
// Property: never crash; anything that decodes satisfies every invariant and re-encodes to the
// very same bytes (the format has one encoding per world). Modes (first input byte): raw input,
// byte patches of a valid delta with the checksum fixed up (to reach the deep checks),
// truncation of a valid delta.

#include <terrain/genesis_delta.h>
#include <terrain/op_script.h>
#include <terrain/procedural_map.h>

#include <xxhash.h>

#include <cstdint>
#include <cstdlib>
#include <optional>
#include <vector>

namespace {

std::optional<terrain::Terrain> g_genesis;
std::vector<std::uint8_t> g_valid;

void fixChecksum(std::vector<std::uint8_t>& b) {
    if (b.size() < 8)
        return;
    const std::uint64_t sum = XXH3_64bits(b.data(), b.size() - 8);
    for (int i = 0; i < 8; ++i)
        b[b.size() - 8 + static_cast<std::size_t>(i)] = static_cast<std::uint8_t>(sum >> (8 * i));
}

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
    std::vector<std::uint8_t> input;
    const int mode = size > 0 ? data[0] % 3 : 0;
    if (mode == 0) {
        input.assign(data, data + size);
    } else if (mode == 1) {
        input = g_valid;
        for (std::size_t i = 1; i + 4 < size; i += 5) {
            const std::uint32_t at = (static_cast<std::uint32_t>(data[i]) << 16) |
                                     (static_cast<std::uint32_t>(data[i + 1]) << 8) | data[i + 2];
            input[at % input.size()] ^= data[i + 3] == 0 ? 1 : data[i + 3];
        }
        if (size > 1 && (data[1] & 1) != 0)
            fixChecksum(input);
    } else {
        std::size_t keep = 0;
        for (std::size_t i = 1; i < size && i < 5; ++i)
            keep = (keep << 8) | data[i];
        input.assign(
            g_valid.begin(),
            g_valid.begin() + static_cast<std::ptrdiff_t>(keep % (g_valid.size() + 1)));
    }
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
