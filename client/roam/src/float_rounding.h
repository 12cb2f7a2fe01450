#pragma once

// Doubles to floats rounded outward, so that a bound stored as a float is still a bound.
// Private to terrain_roam.

#include <cmath>
#include <limits>

namespace terrain::roam::detail {

inline float roundUp(double v) {
    float f = static_cast<float>(v);
    if (static_cast<double>(f) < v)
        f = std::nextafter(f, std::numeric_limits<float>::infinity());
    return f;
}

inline float roundDown(double v) {
    float f = static_cast<float>(v);
    if (static_cast<double>(f) > v)
        f = std::nextafter(f, -std::numeric_limits<float>::infinity());
    return f;
}

} // namespace terrain::roam::detail
