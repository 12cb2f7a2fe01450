#include "support/terrain_builders.h"

#include <terrain/surface_query.h>

#include <glm/geometric.hpp>
#include <gtest/gtest.h>

#include <limits>
#include <random>

namespace terrain {
namespace {

// First crossing found by marching in tiny steps: slow, simple, independent of castRay.
std::optional<double>
marchRay(const Terrain& t, glm::dvec3 o, glm::dvec3 d, double max_s, double step) {
    auto below = [&](double s) {
        const glm::dvec3 p = o + s * d;
        return p.z <= surfaceHeight(t, p.x, p.y);
    };
    auto inside = [&](double s) {
        const glm::dvec3 p = o + s * d;
        return p.x >= 0 && p.y >= 0 && p.x <= t.spec().extentX() && p.y <= t.spec().extentY();
    };
    double prev = 0.0;
    for (double s = 0.0; s <= max_s; s += step) {
        if (inside(s) && below(s)) {
            double lo = prev;
            double hi = s;
            if (!inside(lo) || below(lo))
                return s; // entered the map already below ground
            for (int i = 0; i < 60; ++i) {
                const double mid = 0.5 * (lo + hi);
                (below(mid) ? hi : lo) = mid;
            }
            return hi;
        }
        prev = s;
    }
    return std::nullopt;
}

Terrain crateredHills() {
    Terrain t = testing::makeHills(41, 90, 80);
    CraterSeries s;
    s.seed = 5;
    s.count = 60;
    s.min_radius = 1.0;
    s.max_radius = 5.0;
    testing::applyAll(t, randomCraters(t.spec(), s));
    EXPECT_GT(t.patchCount(), 100u);
    return t;
}

TEST(SurfaceQuery, rayCastsAgreeWithBruteForceMarching) {
    const Terrain t = crateredHills();
    std::mt19937 rng(9);
    std::uniform_real_distribution<double> unit(0.0, 1.0);
    int hits = 0;
    int patch_hits = 0;
    for (int i = 0; i < 300; ++i) {
        // from above the map, downward at 25..85 degrees below horizontal
        const glm::dvec3 o(unit(rng) * 89, unit(rng) * 79, 60.0 + unit(rng) * 10);
        const double az = unit(rng) * 6.2831853;
        const double el = 0.44 + unit(rng) * 1.04;
        const glm::dvec3 d(std::cos(az) * std::cos(el), std::sin(az) * std::cos(el), -std::sin(el));
        const auto cast = castRay(t, o, d, 500.0);
        const auto march = marchRay(t, o, d, 500.0, 0.01);
        ASSERT_EQ(cast.has_value(), march.has_value()) << "ray " << i;
        if (!cast)
            continue;
        ++hits;
        patch_hits += t.findPatch(cast->cell_x, cast->cell_y) != nullptr;
        EXPECT_NEAR(cast->distance, *march, 1e-6) << "ray " << i;
        EXPECT_NEAR(cast->point.z, surfaceHeight(t, cast->point.x, cast->point.y), 1e-6);
        EXPECT_NEAR(glm::length(cast->normal), 1.0, 1e-12);
    }
    EXPECT_GT(hits, 200);
    EXPECT_GT(patch_hits, 10) << "some rays must hit patches";
}

TEST(SurfaceQuery, grazingAndDegenerateRaysAreHandled) {
    const Terrain t = testing::makeFlat(65, 65, 1.0, 10.0);
    EXPECT_FALSE(castRay(t, {10, 10, 20}, {0, 0, 0}, 100).has_value());
    EXPECT_FALSE(castRay(t, {10, 10, 20}, {0, 0, std::nan("")}, 100).has_value());
    EXPECT_FALSE(castRay(t, {10, 10, 20}, {1, 0, 0}, 100).has_value());      // parallel, above
    EXPECT_FALSE(castRay(t, {-50, -50, 20}, {-1, -1, -1}, 100).has_value()); // away from the map
    const auto down = castRay(t, {10.25, 20.75, 20}, {0, 0, -1}, 100);
    ASSERT_TRUE(down.has_value());
    EXPECT_NEAR(down->distance, 10.0, 1e-12);
    EXPECT_NEAR(down->normal.z, 1.0, 1e-12);
    // vertical ray exactly on a grid vertex and on a diagonal
    EXPECT_NEAR(castRay(t, {32, 32, 20}, {0, 0, -1}, 100)->distance, 10.0, 1e-12);
    EXPECT_NEAR(castRay(t, {32.5, 32.5, 20}, {0, 0, -1}, 100)->distance, 10.0, 1e-12);
    // from outside the map, entering it
    const auto in = castRay(t, {-10, 32, 12}, {1, 0, -0.1}, 100);
    ASSERT_TRUE(in.has_value());
    EXPECT_NEAR(in->point.x, 10.0, 1e-9);
    EXPECT_FALSE(castRay(t, {10, 10, 20}, {0, 0, -1}, 5.0).has_value()); // too short
}

TEST(SurfaceQuery, normalsMatchFiniteDifferencesOfHeight) {
    const Terrain t = crateredHills();
    std::mt19937 rng(10);
    std::uniform_real_distribution<double> unit(0.02, 0.98);
    for (int i = 0; i < 500; ++i) {
        const double x = 1 + unit(rng) * 87;
        const double y = 1 + unit(rng) * 77;
        // stay inside one cell and away from base-cell diagonals and patch knot lines
        const double fx = x - std::floor(x);
        const double fy = y - std::floor(y);
        if (std::abs(fx - fy) < 0.02 || std::abs(fx + fy - 1) < 0.02 || std::abs(fx - 0.5) < 0.02 ||
            std::abs(fy - 0.5) < 0.02)
            continue;
        const double e = 1e-5;
        const double dzdx = (surfaceHeight(t, x + e, y) - surfaceHeight(t, x - e, y)) / (2 * e);
        const double dzdy = (surfaceHeight(t, x, y + e) - surfaceHeight(t, x, y - e)) / (2 * e);
        const glm::dvec3 expect = glm::normalize(glm::dvec3(-dzdx, -dzdy, 1.0));
        const glm::dvec3 n = surfaceNormal(t, x, y);
        EXPECT_NEAR(n.x, expect.x, 1e-4);
        EXPECT_NEAR(n.y, expect.y, 1e-4);
        EXPECT_NEAR(n.z, expect.z, 1e-4);
    }
}

TEST(SurfaceQuery, heightIsContinuousAcrossCells) {
    const Terrain t = crateredHills();
    for (int cy = 1; cy < 79; ++cy)
        for (int cx = 1; cx < 89; ++cx) {
            const double x = cx;
            const double y = cy + 0.3;
            EXPECT_NEAR(surfaceHeight(t, x - 1e-12, y), surfaceHeight(t, x + 1e-12, y), 1e-6);
        }
    // outside positions clamp to the edge
    EXPECT_EQ(surfaceHeight(t, -5, 10), surfaceHeight(t, 0, 10));
}

// Regressions: bisection used to spin forever far from the origin or with a huge direction; NaN
// positions used to index the tile array with a negative number.
TEST(SurfaceQuery, farOriginsHugeDirectionsAndNaNAreHandled) {
    Terrain t = testing::makeFlat(65, 65);
    ASSERT_TRUE(t.apply(*quantizeOp({OpKind::kCrater, 32.5, 32.5, 3.0, 1.0, 0.25}, t.spec())).ok());
    ASSERT_NE(t.findPatch(32, 32), nullptr);
    const auto far = castRay(t, {32.4, 32.5, 1e7}, {0, 0, -1}, 1e7 + 10);
    ASSERT_TRUE(far.has_value());
    EXPECT_NEAR(far->point.z, surfaceHeight(t, 32.4, 32.5), 1e-6 * 1e7 * 1e-3);
    EXPECT_FALSE(castRay(t, {32.4, 32.5, 10}, {0, 0, -1e200}, 1.0).has_value());
    EXPECT_FALSE(castRay(t, {1e300, 32.5, 10}, {-1, 0, -1e-300}, 1e300).has_value());
    EXPECT_TRUE(std::isnan(surfaceHeight(t, std::nan(""), 1.0)));
    EXPECT_TRUE(std::isnan(surfaceNormal(t, 3.0, std::nan("")).z));
    EXPECT_EQ(
        surfaceHeight(t, -std::numeric_limits<double>::infinity(), 5.0),
        surfaceHeight(t, 0.0, 5.0));
}

} // namespace
} // namespace terrain
