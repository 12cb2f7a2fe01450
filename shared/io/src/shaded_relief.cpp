#include <terrain/io/shaded_relief.h>
#include <terrain/surface_query.h>

#include <glm/geometric.hpp>

#include <algorithm>
#include <cmath>

namespace terrain::io {
namespace {

struct Rgb {
    double r, g, b;
};

// lowland green -> olive -> brown -> rock grey -> snow, by normalised height
Rgb ramp(double t) {
    static constexpr Rgb kStops[] = {
        {0.20, 0.45, 0.20},
        {0.50, 0.60, 0.30},
        {0.60, 0.45, 0.30},
        {0.60, 0.58, 0.55},
        {0.95, 0.95, 0.97}};
    t = std::clamp(t, 0.0, 1.0) * 4.0;
    const int i = std::min(3, static_cast<int>(t));
    const double f = t - i;
    const Rgb& a = kStops[i];
    const Rgb& b = kStops[i + 1];
    return {a.r + (b.r - a.r) * f, a.g + (b.g - a.g) * f, a.b + (b.b - a.b) * f};
}

} // namespace

RgbImage renderShadedRelief(const Terrain& terrain, const ReliefOptions& o) {
    const WorldSpec& spec = terrain.spec();
    const double h = spec.spacingMetres();
    double x0 = o.x0;
    double y0 = o.y0;
    double x1 = o.x1;
    double y1 = o.y1;
    if (!(x1 > x0 && y1 > y0)) {
        x0 = 0.0;
        y0 = 0.0;
        x1 = spec.extentX();
        y1 = spec.extentY();
    }
    // the region is clipped to the map, and pixels per cell to 64, so the image stays bounded
    x0 = std::clamp(x0, 0.0, spec.extentX());
    y0 = std::clamp(y0, 0.0, spec.extentY());
    x1 = std::clamp(x1, x0, spec.extentX());
    y1 = std::clamp(y1, y0, spec.extentY());
    const int ppc = std::clamp(o.pixels_per_cell, 1, 64);
    const double step = h / ppc;
    RgbImage img;
    img.width = static_cast<std::int32_t>(std::floor((x1 - x0) / step)) + 1;
    img.height = static_cast<std::int32_t>(std::floor((y1 - y0) / step)) + 1;
    img.rgb.resize(static_cast<std::size_t>(img.width) * static_cast<std::size_t>(img.height) * 3);

    double zlo = o.z_low;
    double zhi = o.z_high;
    if (!(zhi > zlo)) {
        const auto samples = terrain.paddedSamples();
        const auto [lo, hi] = std::minmax_element(samples.begin(), samples.end());
        zlo = *lo * spec.metresPerUnit();
        zhi = std::max(zlo + 1e-3, *hi * spec.metresPerUnit());
    }
    const double az = o.sun_azimuth_degrees * M_PI / 180.0;
    const double el = o.sun_elevation_degrees * M_PI / 180.0;
    // image rows run along +y (row 0 of a DEM is north), so azimuth is measured from -y
    const glm::dvec3 sun(std::sin(az) * std::cos(el), -std::cos(az) * std::cos(el), std::sin(el));

    for (std::int32_t py = 0; py < img.height; ++py)
        for (std::int32_t px = 0; px < img.width; ++px) {
            const double x = std::clamp(x0 + px * step, 0.0, spec.extentX());
            const double y = std::clamp(y0 + py * step, 0.0, spec.extentY());
            const double z = surfaceHeight(terrain, x, y);
            glm::dvec3 n = surfaceNormal(terrain, x, y);
            n = glm::normalize(glm::dvec3(n.x * o.exaggeration, n.y * o.exaggeration, n.z));
            const double shade = 0.25 + 0.75 * std::max(0.0, glm::dot(n, sun));
            Rgb c = ramp((z - zlo) / (zhi - zlo));
            if (o.highlight_patches) {
                const auto cx = std::min(static_cast<std::int32_t>(x / h), spec.cellsX() - 1);
                const auto cy = std::min(static_cast<std::int32_t>(y / h), spec.cellsY() - 1);
                if (terrain.findPatch(cx, cy) != nullptr)
                    c = {c.r * 0.75 + 0.25, c.g * 0.8, c.b * 0.8}; // a light red wash
            }
            auto* out = &img.rgb
                             [(static_cast<std::size_t>(py) * static_cast<std::size_t>(img.width) +
                               static_cast<std::size_t>(px)) *
                              3];
            out[0] = static_cast<std::uint8_t>(std::clamp(c.r * shade * 255.0, 0.0, 255.0));
            out[1] = static_cast<std::uint8_t>(std::clamp(c.g * shade * 255.0, 0.0, 255.0));
            out[2] = static_cast<std::uint8_t>(std::clamp(c.b * shade * 255.0, 0.0, 255.0));
        }
    return img;
}

} // namespace terrain::io
