#pragma once

// Image measures of a method's frame against the full-resolution render of the same frame:
// the share of pixels whose largest channel difference exceeds a threshold, and the PSNR over
// the three channels; and popping: the share of pixels whose change from the previous frame
// differs from the full-resolution sequence's change by more than the threshold, i.e. what
// moved because the level of detail changed, not because the camera did; and the LOD change
// alone: last frame's mesh and this frame's, both drawn from this frame's camera. Pure.

#include <terrain/io/png_image.h>

#include <array>
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

/// Share of pixels where `frame` (this frame's mesh) and `previous_mesh` (last frame's mesh
/// drawn from this frame's camera) differ by more than `threshold` in some channel: popping with
/// no camera motion in it (the full-resolution sequence's floor: two meshes that differ move
/// differently on screen as the camera moves, which poppingShare counts). Pixels where the
/// previous mesh shows `sky` are skipped: it may not reach a part of the view that was not in
/// view last frame.
double meshChangeShare(
    const io::RgbImage& previous_mesh,
    const io::RgbImage& frame,
    const std::array<std::uint8_t, 3>& sky,
    int threshold);

} // namespace terrain::lodlab
