#pragma once

// Image measures of a method's frame against the full-resolution render of the same frame:
// the share of pixels whose largest channel difference exceeds a threshold, and the PSNR over
// the three channels; and popping: the share of pixels whose change from the previous frame
// differs from the full-resolution sequence's change by more than the threshold, i.e. what
// moved because the level of detail changed, not because the camera did. Pure.

#include <terrain/io/png_image.h>

#include <cstdint>

namespace terrain::lodlab {

struct ImageError {
    double differing_share = 0.0;
    double psnr_db = 0.0; ///< kPsnrIdentical when the images are equal
};

inline constexpr double kPsnrIdentical = 99.0;

/// Both images of one size (else the share is 1 and the PSNR 0).
ImageError compareImages(const io::RgbImage& frame, const io::RgbImage& reference, int threshold);

/// Share of pixels where (frame - previous) and (reference - reference_previous) differ by more
/// than `threshold` in some channel.
double poppingShare(
    const io::RgbImage& previous,
    const io::RgbImage& frame,
    const io::RgbImage& reference_previous,
    const io::RgbImage& reference,
    int threshold);

} // namespace terrain::lodlab
