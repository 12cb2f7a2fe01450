#include <terrain/lodlab/image_measure.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>

namespace terrain::lodlab {
namespace {

bool sameSize(const io::RgbImage& a, const io::RgbImage& b) {
    return a.width == b.width && a.height == b.height && a.rgb.size() == b.rgb.size() &&
           !a.rgb.empty();
}

} // namespace

ImageError compareImages(const io::RgbImage& frame, const io::RgbImage& reference, int threshold) {
    ImageError e;
    if (!sameSize(frame, reference)) {
        e.differing_share = 1.0;
        return e;
    }
    std::int64_t differing = 0;
    double squares = 0.0;
    const std::size_t pixels = frame.rgb.size() / 3;
    for (std::size_t p = 0; p < pixels; ++p) {
        int worst = 0;
        for (std::size_t c = 0; c < 3; ++c) {
            const int d = int{frame.rgb[3 * p + c]} - int{reference.rgb[3 * p + c]};
            worst = std::max(worst, std::abs(d));
            squares += static_cast<double>(d) * d;
        }
        differing += worst > threshold ? 1 : 0;
    }
    e.differing_share = static_cast<double>(differing) / static_cast<double>(pixels);
    const double mse = squares / static_cast<double>(frame.rgb.size());
    e.psnr_db = mse == 0.0 ? kPsnrIdentical : 10.0 * std::log10(255.0 * 255.0 / mse);
    return e;
}

double poppingShare(
    const io::RgbImage& previous,
    const io::RgbImage& frame,
    const io::RgbImage& reference_previous,
    const io::RgbImage& reference,
    int threshold) {
    if (!sameSize(previous, frame) || !sameSize(frame, reference) ||
        !sameSize(reference, reference_previous))
        return 1.0;
    std::int64_t popped = 0;
    const std::size_t pixels = frame.rgb.size() / 3;
    for (std::size_t p = 0; p < pixels; ++p) {
        int worst = 0;
        for (std::size_t c = 0; c < 3; ++c) {
            const std::size_t i = 3 * p + c;
            const int ours = int{frame.rgb[i]} - int{previous.rgb[i]};
            const int truth = int{reference.rgb[i]} - int{reference_previous.rgb[i]};
            worst = std::max(worst, std::abs(ours - truth));
        }
        popped += worst > threshold ? 1 : 0;
    }
    return static_cast<double>(popped) / static_cast<double>(pixels);
}

double meshChangeShare(
    const io::RgbImage& previous_mesh,
    const io::RgbImage& frame,
    const std::array<std::uint8_t, 3>& sky,
    int threshold) {
    if (!sameSize(previous_mesh, frame))
        return 1.0;
    std::int64_t changed = 0;
    const std::size_t pixels = frame.rgb.size() / 3;
    for (std::size_t p = 0; p < pixels; ++p) {
        const std::uint8_t* was = previous_mesh.rgb.data() + 3 * p;
        if (was[0] == sky[0] && was[1] == sky[1] && was[2] == sky[2])
            continue;
        int worst = 0;
        for (std::size_t c = 0; c < 3; ++c)
            worst = std::max(worst, std::abs(int{frame.rgb[3 * p + c]} - int{was[c]}));
        changed += worst > threshold ? 1 : 0;
    }
    return static_cast<double>(changed) / static_cast<double>(std::max<std::size_t>(pixels, 1));
}

} // namespace terrain::lodlab
