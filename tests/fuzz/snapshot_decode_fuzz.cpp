// libFuzzer target: snapshot decoding (untrusted bytes from disk or the network).
// Property: never crash; anything that decodes satisfies every invariant and re-encodes to the
// very same bytes. Modes (first input byte): raw input, byte patches of a valid snapshot with the
// checksum fixed up (to reach the deep checks), truncation of a valid snapshot.

#include <terrain/op_script.h>
#include <terrain/procedural_map.h>
#include <terrain/snapshot.h>

#include <xxhash.h>

#include <cstdint>
#include <cstdlib>
#include <vector>

namespace {

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
    auto decoded = terrain::decodeSnapshot(input);
    if (!decoded)
        return 0;
    if (!decoded->terrain.checkInvariants().ok())
        std::abort();
    if (terrain::encodeSnapshot(decoded->terrain, decoded->sequence) != input)
        std::abort();
    return 0;
}
