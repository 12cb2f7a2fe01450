#include "support/terrain_builders.h"

#include <terrain/deform_op.h>
#include <terrain/pointwise_op.h>

#include <gtest/gtest.h>

#include <cmath>
#include <limits>

namespace terrain {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
constexpr double kInf = std::numeric_limits<double>::infinity();

struct BadCase {
    const char* name;
    OpRequest request;
    ErrorCode code;
    const char* says; // a word the message must contain
};

// Each refusal names the rule broken and leaves the state untouched.
TEST(DeformOp, badRequestsAreRefusedWithTheRuleAndChangeNothing) {
    Terrain t = testing::makeHills(11);
    const std::uint64_t before = t.worldHash();
    const BadCase cases[] = {
        {"nan x", {OpKind::kCrater, kNaN, 10, 3, 1, 0.2}, ErrorCode::kNotFinite, "x"},
        {"inf y", {OpKind::kCrater, 10, kInf, 3, 1, 0.2}, ErrorCode::kNotFinite, "y"},
        {"nan radius", {OpKind::kCrater, 10, 10, kNaN, 1, 0.2}, ErrorCode::kNotFinite, "radius"},
        {"-inf height", {OpKind::kRaise, 10, 10, 3, -kInf, 1}, ErrorCode::kNotFinite, "height"},
        {"nan strength", {OpKind::kSmooth, 10, 10, 3, 0, kNaN}, ErrorCode::kNotFinite, "strength"},
        {"zero radius", {OpKind::kCrater, 10, 10, 0, 1, 0.2}, ErrorCode::kOutOfRange, "radius"},
        {"negative radius",
         {OpKind::kCrater, 10, 10, -2, 1, 0.2},
         ErrorCode::kOutOfRange,
         "radius"},
        {"tiny radius", {OpKind::kCrater, 10, 10, 0.01, 1, 0.2}, ErrorCode::kOutOfRange, "radius"},
        {"huge radius", {OpKind::kCrater, 10, 10, 1e6, 1, 0.2}, ErrorCode::kOutOfRange, "radius"},
        {"absurd radius",
         {OpKind::kCrater, 10, 10, 1e300, 1, 0.2},
         ErrorCode::kOutOfRange,
         "radius"},
        {"centre west", {OpKind::kCrater, -0.5, 10, 3, 1, 0.2}, ErrorCode::kOutsideMap, "outside"},
        {"centre south",
         {OpKind::kCrater, 10, 139.01, 3, 1, 0.2},
         ErrorCode::kOutsideMap,
         "outside"},
        {"centre far", {OpKind::kCrater, 1e12, 1e12, 3, 1, 0.2}, ErrorCode::kOutOfRange, "x"},
        {"zero depth", {OpKind::kCrater, 10, 10, 3, 0, 0.2}, ErrorCode::kOutOfRange, "depth"},
        {"negative depth", {OpKind::kCrater, 10, 10, 3, -1, 0.2}, ErrorCode::kOutOfRange, "depth"},
        {"deep crater", {OpKind::kCrater, 10, 10, 3, 5000, 0.2}, ErrorCode::kOutOfRange, "depth"},
        {"rim above 1", {OpKind::kCrater, 10, 10, 3, 1, 1.5}, ErrorCode::kOutOfRange, "strength"},
        {"zero raise", {OpKind::kRaise, 10, 10, 3, 0, 1}, ErrorCode::kOutOfRange, "raise"},
        {"flatten zero strength",
         {OpKind::kFlatten, 10, 10, 3, 4, 0},
         ErrorCode::kOutOfRange,
         "strength"},
        {"smooth with height",
         {OpKind::kSmooth, 10, 10, 3, 2, 0.5},
         ErrorCode::kOutOfRange,
         "height"},
        {"unknown kind",
         {static_cast<OpKind>(9), 10, 10, 3, 1, 0.5},
         ErrorCode::kUnsupported,
         "kind"},
    };
    for (const BadCase& c : cases) {
        auto op = quantizeOp(c.request, t.spec());
        ASSERT_FALSE(op.ok()) << c.name;
        EXPECT_EQ(op.error().code, c.code) << c.name << ": " << op.error().message;
        EXPECT_NE(op.error().message.find(c.says), std::string::npos)
            << c.name << ": " << op.error().message;
        EXPECT_EQ(t.worldHash(), before) << c.name;
    }
}

TEST(DeformOp, canonicalOpsFromTheWireAreValidatedToo) {
    Terrain t = testing::makeHills(12);
    const std::uint64_t before = t.worldHash();
    DeformOp op;
    op.kind = OpKind::kCrater;
    op.center_x = 20 * 1024;
    op.center_y = 20 * 1024;
    op.radius = 3 * 1024;
    op.height = 1024;
    op.strength = kUnitStrength / 4;
    ASSERT_TRUE(t.apply(op).ok());
    const std::uint64_t after = t.worldHash();
    EXPECT_NE(after, before);

    DeformOp bad = op;
    bad.center_x = -1;
    EXPECT_EQ(t.apply(bad).error().code, ErrorCode::kOutsideMap);
    bad = op;
    bad.radius = std::numeric_limits<std::int32_t>::max();
    EXPECT_EQ(t.apply(bad).error().code, ErrorCode::kOutOfRange);
    bad = op;
    bad.strength = -5;
    EXPECT_EQ(t.apply(bad).error().code, ErrorCode::kOutOfRange);
    bad = op;
    bad.center_y = std::numeric_limits<std::int64_t>::min();
    EXPECT_EQ(t.apply(bad).error().code, ErrorCode::kOutsideMap);
    EXPECT_EQ(t.worldHash(), after);
}

TEST(DeformOp, quantizationRoundsToTheNearestQuantum) {
    const Terrain t = testing::makeFlat(65, 65);
    auto op = quantizeOp({OpKind::kCrater, 10.0004, 20.0, 2.5, 1.25, 0.25}, t.spec());
    ASSERT_TRUE(op.ok());
    EXPECT_EQ(op->center_x, 10240);
    EXPECT_EQ(op->radius, 2560);
    EXPECT_EQ(op->height, 1280);
    EXPECT_EQ(op->strength, kUnitStrength / 4);
    EXPECT_EQ(describe(*op, t.spec()), "crater x=10.000 y=20.000 r=2.500 h=1.250 s=0.2500");
}

TEST(DeformOp, craterProfileHasBowlRimAndEjecta) {
    // on flat ground at 0 the crater is its profile: bowl, rim at R, ejecta falling to 0 at 2R
    DeformOp op{OpKind::kCrater, 0, 0, 1024, 1024, kUnitStrength / 4};
    const PointwiseOp f(op, BlastGround{});
    const auto at = [&](double r_m) {
        return f.height(static_cast<std::int64_t>(r_m * 1024 * 48), 0, 0, 0) / 48.0 / 1024.0;
    };
    EXPECT_NEAR(at(0.0), -1.0, 1e-4);
    EXPECT_NEAR(at(1.0), 0.25, 1e-3);   // rim
    EXPECT_NEAR(at(1.5), 0.0625, 1e-3); // ejecta 0.25 * (2 - 1.5)^2
    EXPECT_EQ(at(2.0), 0.0);
    EXPECT_EQ(at(5.0), 0.0);
    EXPECT_LT(at(0.5), 0.0);
}

TEST(DeformOp, craterDeeperThanItsRadiusIsRefusedByName) {
    const Terrain t = testing::makeFlat(65, 65);
    auto op = quantizeOp({OpKind::kCrater, 30, 30, 2.0, 2.5, 0.25}, t.spec());
    ASSERT_FALSE(op.ok());
    EXPECT_EQ(op.error().code, ErrorCode::kOutOfRange);
    EXPECT_NE(op.error().message.find("crater depth (at most the radius)"), std::string::npos)
        << op.error().message;
    EXPECT_TRUE(quantizeOp({OpKind::kCrater, 30, 30, 2.0, 2.0, 0.25}, t.spec()).ok());
}

} // namespace
} // namespace terrain
