#pragma once

// Doubles to floats rounded outward, so that a bound stored as a float is still a bound.
// Private to terrain_roam.
//
// The step to the next float is made on the bits (as std::nextafter would make it, without its
// call: these run a few times for every diamond bound).

#include <bit>
#include <cstdint>

namespace terrain::roam::detail {

/// The next float above f (f not NaN, not +inf): -0 and +0 step to the smallest subnormal.
inline float nextUp(float f) {
    const auto bits = std::bit_cast<std::uint32_t>(f);
    if ((bits & 0x7fffffffu) == 0)
        return std::bit_cast<float>(std::uint32_t{1});
    return std::bit_cast<float>((bits & 0x80000000u) != 0 ? bits - 1 : bits + 1);
}

/// The next float below f (f not NaN, not -inf).
inline float nextDown(float f) {
    return -nextUp(-f);
}

inline float roundUp(double v) {
    const auto f = static_cast<float>(v);
    return static_cast<double>(f) < v ? nextUp(f) : f;
}

inline float roundDown(double v) {
    const auto f = static_cast<float>(v);
    return static_cast<double>(f) > v ? nextDown(f) : f;
}

} // namespace terrain::roam::detail
