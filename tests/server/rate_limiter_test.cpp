#include <terrain/server/rate_limiter.h>

#include <gtest/gtest.h>

#include <limits>

namespace terrain::server {
namespace {

constexpr double kStart = 100.0; // non-zero start time, as the core never reads a clock
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
constexpr double kInf = std::numeric_limits<double>::infinity();

TEST(RateLimiter, startsFullAndAllowsExactlyTheBurst) {
    RateLimiter limiter(/*rate_per_second=*/2.0, /*burst=*/5.0);
    for (int i = 0; i < 5; ++i)
        EXPECT_TRUE(limiter.tryConsume(kStart)) << i;
    EXPECT_FALSE(limiter.tryConsume(kStart));
    EXPECT_DOUBLE_EQ(limiter.available(), 0.0);
}

TEST(RateLimiter, refillsAtTheRateAfterTheBurst) {
    RateLimiter limiter(2.0, 3.0);
    for (int i = 0; i < 3; ++i)
        ASSERT_TRUE(limiter.tryConsume(kStart));
    EXPECT_FALSE(limiter.tryConsume(kStart + 0.25)); // half a token
    EXPECT_TRUE(limiter.tryConsume(kStart + 0.5));   // one token
    EXPECT_FALSE(limiter.tryConsume(kStart + 0.5));
    EXPECT_TRUE(limiter.tryConsume(kStart + 1.5)); // two more
    EXPECT_TRUE(limiter.tryConsume(kStart + 1.5));
    EXPECT_FALSE(limiter.tryConsume(kStart + 1.5));
}

TEST(RateLimiter, timeGoingBackwardsCreditsNothing) {
    RateLimiter limiter(2.0, 2.0);
    ASSERT_TRUE(limiter.tryConsume(kStart, 2.0));
    EXPECT_FALSE(limiter.tryConsume(kStart - 50.0));
    EXPECT_FALSE(limiter.tryConsume(kStart - 1e12));
    // coming back to the latest time seen credits nothing either
    EXPECT_FALSE(limiter.tryConsume(kStart));
    EXPECT_FALSE(limiter.tryConsume(kStart + 0.25));
    EXPECT_TRUE(limiter.tryConsume(kStart + 0.5));
}

TEST(RateLimiter, backwardsTimeStillSpendsWhatIsLeft) {
    RateLimiter limiter(1.0, 3.0);
    ASSERT_TRUE(limiter.tryConsume(kStart));
    EXPECT_TRUE(limiter.tryConsume(kStart - 10.0));
    EXPECT_TRUE(limiter.tryConsume(kStart - 20.0));
    EXPECT_FALSE(limiter.tryConsume(kStart - 30.0));
}

TEST(RateLimiter, hugeGapsRefillOnlyToTheBurst) {
    RateLimiter limiter(1e300, 4.0);
    for (int i = 0; i < 4; ++i)
        ASSERT_TRUE(limiter.tryConsume(kStart));
    ASSERT_FALSE(limiter.tryConsume(kStart));
    // (1e300 - 100) * 1e300 overflows to infinity; the bucket still holds only the burst
    for (int i = 0; i < 4; ++i)
        EXPECT_TRUE(limiter.tryConsume(1e300)) << i;
    EXPECT_FALSE(limiter.tryConsume(1e300));

    RateLimiter slow(0.5, 2.0);
    ASSERT_TRUE(slow.tryConsume(kStart, 2.0));
    EXPECT_TRUE(slow.tryConsume(kStart + 1e9, 0.0));
    EXPECT_DOUBLE_EQ(slow.available(), 2.0);
}

TEST(RateLimiter, fractionalCostsAddUp) {
    RateLimiter quarters(0.0, 1.0);
    for (int i = 0; i < 4; ++i)
        EXPECT_TRUE(quarters.tryConsume(kStart, 0.25)) << i;
    EXPECT_FALSE(quarters.tryConsume(kStart, 0.25));

    // 0.01 is not exact in binary: after 99 of them 0.00999999999999925 is left, which the
    // tolerance still counts as enough for the hundredth; a 101st is refused
    RateLimiter hundredths(0.0, 1.0);
    for (int i = 0; i < 100; ++i)
        EXPECT_TRUE(hundredths.tryConsume(kStart, 0.01)) << i;
    EXPECT_FALSE(hundredths.tryConsume(kStart, 0.01));

    RateLimiter refill(1.0, 1.0);
    ASSERT_TRUE(refill.tryConsume(kStart, 1.0));
    EXPECT_FALSE(refill.tryConsume(kStart + 0.5, 0.75));
    EXPECT_TRUE(refill.tryConsume(kStart + 0.75, 0.75));
    EXPECT_NEAR(refill.available(), 0.0, 1e-12);
}

TEST(RateLimiter, refusalsTakeNothing) {
    RateLimiter limiter(1.0, 2.0);
    ASSERT_TRUE(limiter.tryConsume(kStart, 1.5));
    EXPECT_FALSE(limiter.tryConsume(kStart, 1.0)); // 0.5 left
    EXPECT_TRUE(limiter.tryConsume(kStart, 0.5));
}

TEST(RateLimiter, badCostsAndTimesAreRefusedAndChangeNothing) {
    RateLimiter limiter(1.0, 2.0);
    ASSERT_TRUE(limiter.tryConsume(kStart, 1.0));
    for (const double cost : {kNaN, kInf, -kInf, -1.0, -1e-300, 2.5})
        EXPECT_FALSE(limiter.tryConsume(kStart, cost)) << cost;
    for (const double now : {kNaN, kInf, -kInf})
        EXPECT_FALSE(limiter.tryConsume(now, 0.5)) << now;
    EXPECT_DOUBLE_EQ(limiter.available(), 1.0);
    // no refill was credited by the refused calls: one second later there are exactly 2
    EXPECT_TRUE(limiter.tryConsume(kStart + 1.0, 2.0));
    EXPECT_FALSE(limiter.tryConsume(kStart + 1.0, 0.01));
}

TEST(RateLimiter, costAboveBurstNeverSucceedsAndZeroCostAlwaysDoes) {
    RateLimiter limiter(10.0, 3.0);
    EXPECT_FALSE(limiter.tryConsume(kStart, 3.0 + 1e-10));
    EXPECT_FALSE(limiter.tryConsume(kStart + 1e6, 4.0));
    EXPECT_TRUE(limiter.tryConsume(kStart + 1e6, 3.0));
    EXPECT_TRUE(limiter.tryConsume(kStart + 1e6, 0.0));
}

TEST(RateLimiter, zeroRateNeverRefills) {
    RateLimiter limiter(0.0, 1.0);
    ASSERT_TRUE(limiter.tryConsume(kStart));
    EXPECT_FALSE(limiter.tryConsume(kStart + 1e9));
}

TEST(RateLimiter, sameCallsGiveTheSameAnswers) {
    RateLimiter a(3.0, 4.0);
    RateLimiter b(3.0, 4.0);
    double t = kStart;
    for (int i = 0; i < 1000; ++i) {
        t += (i % 7) * 0.037 - 0.05; // sometimes backwards
        const double cost = 0.3 + (i % 5) * 0.4;
        ASSERT_EQ(a.tryConsume(t, cost), b.tryConsume(t, cost)) << i;
        ASSERT_EQ(a.available(), b.available()) << i;
    }
}

TEST(RateLimiter, checkParametersRefusesBadConfiguration) {
    EXPECT_TRUE(RateLimiter::checkParameters(0.0, 1.0).ok());
    EXPECT_TRUE(RateLimiter::checkParameters(20.0, 40.0).ok());
    struct Case {
        double rate;
        double burst;
        ErrorCode code;
    };
    const Case cases[] = {
        {kNaN, 1.0, ErrorCode::kNotFinite},  {kInf, 1.0, ErrorCode::kNotFinite},
        {1.0, kNaN, ErrorCode::kNotFinite},  {1.0, kInf, ErrorCode::kNotFinite},
        {-1.0, 1.0, ErrorCode::kOutOfRange}, {1.0, 0.0, ErrorCode::kOutOfRange},
        {1.0, -1.0, ErrorCode::kOutOfRange},
    };
    for (const Case& c : cases) {
        const Status s = RateLimiter::checkParameters(c.rate, c.burst);
        ASSERT_FALSE(s.ok()) << c.rate << " " << c.burst;
        EXPECT_EQ(s.error().code, c.code) << c.rate << " " << c.burst;
    }
}

} // namespace
} // namespace terrain::server
