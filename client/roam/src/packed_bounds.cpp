#include "float_rounding.h"

#include <terrain/roam/packed_bounds.h>

#include <algorithm>
#include <bit>
#include <cmath>
#include <limits>

namespace terrain::roam {

namespace {

constexpr int kMantissaBits = 11;
constexpr std::uint32_t kDroppedBits = 23 - kMantissaBits;
/// A code's exponent field e (1..31) is the float exponent kExponentBias + e.
constexpr std::uint32_t kExponentBias = 110;
constexpr std::uint16_t kInfinityCode = 0xffff;

std::uint64_t packStep(double steps) {
    const double limit = BoundsCodec::kStepLimit;
    const double clamped = std::clamp(steps, -limit, limit - 1.0);
    return static_cast<std::uint64_t>(static_cast<std::int64_t>(clamped) + BoundsCodec::kStepLimit);
}

} // namespace

BoundsCodec::BoundsCodec(double metres_per_quantum)
    : metres_per_step_(metres_per_quantum * kQuantaPerStep),
      steps_per_metre_(1.0 / (metres_per_quantum * kQuantaPerStep)) {}

std::uint16_t BoundsCodec::packDelta(float delta) {
    if (!(delta > 0.0f))
        return 0;
    if (!std::isfinite(delta))
        return kInfinityCode;
    const std::uint32_t bits = std::bit_cast<std::uint32_t>(delta);
    const std::uint32_t exponent = bits >> 23;
    if (exponent <= kExponentBias)
        return std::uint16_t{1} << kMantissaBits; // below 2^-16 m: the smallest code above it
    const std::uint32_t mantissa = bits & 0x7fffffu;
    std::uint32_t code = ((exponent - kExponentBias) << kMantissaBits) | (mantissa >> kDroppedBits);
    if ((mantissa & ((1u << kDroppedBits) - 1)) != 0)
        ++code; // up; a carry into the exponent is the next power of two, exactly
    return code >= kInfinityCode ? kInfinityCode : static_cast<std::uint16_t>(code);
}

float BoundsCodec::unpackDelta(std::uint16_t code) {
    if (code == 0)
        return 0.0f;
    if (code == kInfinityCode)
        return std::numeric_limits<float>::infinity();
    const std::uint32_t exponent =
        (static_cast<std::uint32_t>(code) >> kMantissaBits) + kExponentBias;
    const std::uint32_t mantissa = (static_cast<std::uint32_t>(code) & ((1u << kMantissaBits) - 1))
                                   << kDroppedBits;
    return std::bit_cast<float>((exponent << 23) | mantissa);
}

PackedBounds BoundsCodec::pack(const DiamondBounds& b) const {
    const std::uint64_t lo = packStep(std::floor(static_cast<double>(b.zlo) * steps_per_metre_));
    const std::uint64_t hi = packStep(std::ceil(static_cast<double>(b.zhi) * steps_per_metre_));
    return {packDelta(b.delta) | (lo << 16) | (hi << 40)};
}

DiamondBounds BoundsCodec::unpack(PackedBounds p) const {
    const auto step = [](std::uint64_t field) {
        return static_cast<double>(static_cast<std::int64_t>(field & 0xffffffu) - kStepLimit);
    };
    return {
        unpackDelta(static_cast<std::uint16_t>(p.bits & 0xffffu)),
        detail::roundDown(step(p.bits >> 16) * metres_per_step_),
        detail::roundUp(step(p.bits >> 40) * metres_per_step_)};
}

} // namespace terrain::roam
