// libFuzzer target: canonical ops as they arrive from the wire (untrusted integers).
// Property: never crash; after any sequence of ops, applied or refused, every patch invariant
// holds and every incremental hash equals a recomputation.

#include <terrain/deform_op.h>
#include <terrain/procedural_map.h>
#include <terrain/terrain.h>

#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <optional>

namespace {

std::optional<terrain::Terrain> g_world;

template <typename T> T take(const std::uint8_t*& p, const std::uint8_t* end) {
    T v{};
    const std::size_t n = std::min<std::size_t>(sizeof(T), static_cast<std::size_t>(end - p));
    std::memcpy(&v, p, n);
    p += n;
    return v;
}

} // namespace

extern "C" int LLVMFuzzerInitialize(int*, char***) {
    terrain::ProceduralMapOptions o;
    o.width = 140;
    o.height = 90;
    o.seed = 5;
    o.wavelength_metres = 32.0;
    g_world.emplace(std::move(*terrain::makeProceduralMap(o)));
    return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    terrain::Terrain t = *g_world;
    const terrain::WorldSpec& spec = t.spec();
    const std::uint8_t* p = data;
    const std::uint8_t* end = data + size;
    for (int n = 0; n < 16 && p < end; ++n) {
        terrain::DeformOp op;
        const auto mode = take<std::uint8_t>(p, end);
        op.kind = static_cast<terrain::OpKind>(mode & 7);
        if ((mode & 8) != 0) {
            // raw fields: mostly refused, which must leave the state untouched
            op.center_x = take<std::int64_t>(p, end);
            op.center_y = take<std::int64_t>(p, end);
            op.radius = take<std::int32_t>(p, end);
            op.height = take<std::int32_t>(p, end);
            op.strength = take<std::int32_t>(p, end);
        } else {
            // fields mapped into their valid ranges, so ops land and interact
            const terrain::RadiusRange rr = terrain::radiusRange(spec);
            op.center_x =
                take<std::uint16_t>(p, end) % (std::int64_t{spec.cellsX()} * spec.spacing + 1);
            op.center_y =
                take<std::uint16_t>(p, end) * 4 % (std::int64_t{spec.cellsY()} * spec.spacing + 1);
            op.radius = rr.min + static_cast<std::int32_t>(take<std::uint16_t>(p, end) % 16384);
            op.height = static_cast<std::int32_t>(take<std::int16_t>(p, end)) * 8;
            op.strength = static_cast<std::int32_t>(take<std::uint16_t>(p, end)) + 1;
        }
        const std::uint64_t before = t.worldHash();
        if (!t.apply(op).ok() && t.worldHash() != before)
            std::abort(); // a refusal changed the state
    }
    if (!t.checkInvariants().ok())
        std::abort();
    for (std::int32_t tile = 0; tile < spec.tileCount(); ++tile)
        if (t.tileHash(tile) != t.computeTileHash(tile))
            std::abort();
    if (t.worldHash() != t.computeWorldHash())
        std::abort();
    return 0;
}
