// The tessellator's 8-byte bounds: never tighter than the exact ones, close to them, and monotone
// (what keeps a parent's packed bounds above its child's).

#include <terrain/roam/packed_bounds.h>

#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <limits>
#include <random>

namespace terrain::roam {
namespace {

TEST(PackedBounds, DeltaRoundsUpWithinOnePartIn2048AndKeepsOrder) {
    std::mt19937 rng(7);
    std::uniform_real_distribution<double> log2_of(-16.0, 14.9);
    float previous_exact = 0.0f;
    std::uint16_t previous_code = 0;
    std::vector<float> values;
    for (int i = 0; i < 200000; ++i)
        values.push_back(static_cast<float>(std::exp2(log2_of(rng))));
    std::sort(values.begin(), values.end());
    for (const float d : values) {
        const std::uint16_t code = BoundsCodec::packDelta(d);
        const float back = BoundsCodec::unpackDelta(code);
        ASSERT_GE(back, d) << "a packed delta must not be tighter";
        ASSERT_LE(back, d * (1.0f + 1.0f / 2048.0f)) << d;
        ASSERT_GE(code, previous_code)
            << "packing must keep order: " << previous_exact << " < " << d;
        previous_exact = d;
        previous_code = code;
    }
    // exactly representable values come back as they are
    EXPECT_EQ(BoundsCodec::unpackDelta(BoundsCodec::packDelta(0.0f)), 0.0f);
    EXPECT_EQ(BoundsCodec::unpackDelta(BoundsCodec::packDelta(1.0f)), 1.0f);
    EXPECT_EQ(BoundsCodec::unpackDelta(BoundsCodec::packDelta(0.75f)), 0.75f);
    // a mantissa of all ones rounds up into the next power of two
    EXPECT_EQ(BoundsCodec::unpackDelta(BoundsCodec::packDelta(std::nextafter(2.0f, 0.0f))), 2.0f);
    // tiny values go up to the smallest code, huge ones to infinity: still bounds
    EXPECT_GE(BoundsCodec::unpackDelta(BoundsCodec::packDelta(1e-9f)), 1e-9f);
    EXPECT_GT(BoundsCodec::unpackDelta(BoundsCodec::packDelta(1e-9f)), 0.0f);
    EXPECT_TRUE(std::isinf(BoundsCodec::unpackDelta(BoundsCodec::packDelta(1e6f))));
    EXPECT_TRUE(std::isinf(
        BoundsCodec::unpackDelta(BoundsCodec::packDelta(std::numeric_limits<float>::infinity()))));
}

TEST(PackedBounds, TheBoxWidensByLessThanOneStepAndNestingSurvives) {
    const double metres_per_quantum = 1.0 / 1024.0;
    const BoundsCodec codec(metres_per_quantum);
    const double step = metres_per_quantum * BoundsCodec::kQuantaPerStep;
    std::mt19937 rng(11);
    std::uniform_real_distribution<double> z(-3000.0, 9000.0);
    std::uniform_real_distribution<double> span(0.0, 50.0);
    std::uniform_real_distribution<double> inside(0.0, 1.0);
    for (int i = 0; i < 100000; ++i) {
        // a parent and a child whose exact bounds nest
        DiamondBounds parent{static_cast<float>(span(rng)), static_cast<float>(z(rng)), 0.0f};
        parent.zhi = parent.zlo + static_cast<float>(span(rng));
        DiamondBounds child{
            static_cast<float>(parent.delta * inside(rng)),
            static_cast<float>(parent.zlo + (parent.zhi - parent.zlo) * inside(rng) * 0.5), 0.0f};
        child.zhi = std::min(
            parent.zhi, static_cast<float>(child.zlo + (parent.zhi - child.zlo) * inside(rng)));
        if (i % 7 == 0)
            child.zhi = parent.zhi; // the extreme shared, as it often is
        if (i % 5 == 0)
            child.delta = parent.delta;
        const DiamondBounds p = codec.outward(parent);
        const DiamondBounds c = codec.outward(child);
        ASSERT_GE(p.delta, parent.delta);
        ASSERT_LE(p.zlo, parent.zlo);
        ASSERT_GE(p.zhi, parent.zhi);
        ASSERT_GT(static_cast<double>(p.zlo), parent.zlo - step * 1.001);
        ASSERT_LT(static_cast<double>(p.zhi), parent.zhi + step * 1.001);
        ASSERT_LE(c.delta, p.delta) << "a packed child above its packed parent";
        ASSERT_GE(c.zlo, p.zlo);
        ASSERT_LE(c.zhi, p.zhi);
        ASSERT_EQ(codec.pack(p), codec.pack(parent)) << "packing what was unpacked changes nothing";
    }
    const DiamondBounds zero = codec.unpack(PackedBounds{});
    EXPECT_EQ(zero.delta, 0.0f);
    EXPECT_EQ(zero.zlo, 0.0f);
    EXPECT_EQ(zero.zhi, 0.0f);
}

TEST(PackedBounds, HeightsBeyondTheCoreLimitAreClampedOutsideIt) {
    // the finest quantum the core allows, where the steps' reach is smallest
    const double metres_per_quantum = 1.0 / 65536.0;
    const BoundsCodec codec(metres_per_quantum);
    const double limit = (1 << 27) * metres_per_quantum; // kMaxHeightQuanta
    const DiamondBounds wide = codec.outward({1.0f, -1e9f, 1e9f});
    EXPECT_LE(wide.zlo, -limit);
    EXPECT_GE(wide.zhi, limit);
    const DiamondBounds edge =
        codec.outward({0.5f, static_cast<float>(-limit - 0.5), static_cast<float>(limit + 0.5)});
    EXPECT_LE(edge.zlo, -limit - 0.5);
    EXPECT_GE(edge.zhi, limit + 0.5);
}

} // namespace
} // namespace terrain::roam
