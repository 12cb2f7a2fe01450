#pragma once

// A diamond's stored bounds in 8 bytes instead of 12 (Tread Marks kept one-byte variances; we
// keep the guarantee): `delta` as a 16-bit unsigned float (11 mantissa bits, 2^-16 m to 32 km,
// larger is +infinity) rounded up, and the box's z range as two 24-bit steps of 32 quanta from
// the world's zero, zlo rounded down and zhi up. Unpacked bounds are therefore never tighter
// than the exact ones (a priority from them is still an upper bound), at most 2^-11 larger in
// delta and one step wider in z (3 cm at 1,024 quanta a metre). Every rounding is to a fixed
// grid of values, so it is monotone: a parent whose exact bounds hold its child's still holds
// them once both are packed. The z steps cover +-2^28 quanta, twice the core's height limit, and
// values beyond are clamped there (the geometry a box must hold never leaves +-kMaxHeightQuanta).
// Pure, no state beyond the world's scale.

#include <terrain/roam/block_bounds.h>

#include <cstdint>

namespace terrain::roam {

struct PackedBounds {
    /// bits 0-15 delta, 16-39 zlo + 2^23, 40-63 zhi + 2^23 (so the default is {0, 0, 0})
    std::uint64_t bits = (std::uint64_t{1} << 39) | (std::uint64_t{1} << 63);
    friend bool operator==(PackedBounds a, PackedBounds b) { return a.bits == b.bits; }
};
static_assert(sizeof(PackedBounds) == 8);

class BoundsCodec {
  public:
    static constexpr std::int32_t kQuantaPerStep = 32;
    static constexpr std::int32_t kStepLimit = 1 << 23;

    BoundsCodec() = default;
    /// `metres_per_quantum`: the world's height quantum.
    explicit BoundsCodec(double metres_per_quantum);

    PackedBounds pack(const DiamondBounds& b) const;
    DiamondBounds unpack(PackedBounds p) const;
    /// What storing `b` gives back: the bounds anything compared with stored ones must use.
    DiamondBounds outward(const DiamondBounds& b) const { return unpack(pack(b)); }

    static std::uint16_t packDelta(float delta);
    static float unpackDelta(std::uint16_t code);

  private:
    double metres_per_step_ = 1.0 / 32.0;
    double steps_per_metre_ = 32.0;
};

} // namespace terrain::roam
