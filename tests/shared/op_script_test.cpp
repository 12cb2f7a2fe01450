#include <terrain/op_script.h>

#include <gtest/gtest.h>

namespace terrain {
namespace {

TEST(OpScript, parsesEveryKindWithDefaultsAndComments) {
    auto ops =
        parseOpScript("# comment\n\ncrater 1 2 3 4\ncrater 1 2 3 4 0.5  # inline\n"
                      "raise 5 6 7 -8\r\nflatten 1 1 2 30 0.5\nsmooth 3 3 4\nsmooth 3 3 4 0.25\n");
    ASSERT_TRUE(ops.ok()) << ops.error().message;
    ASSERT_EQ(ops->size(), 6u);
    EXPECT_EQ((*ops)[0].kind, OpKind::kCrater);
    EXPECT_EQ((*ops)[0].strength, 0.25);
    EXPECT_EQ((*ops)[1].strength, 0.5);
    EXPECT_EQ((*ops)[2].height, -8.0);
    EXPECT_EQ((*ops)[3].strength, 0.5);
    EXPECT_EQ((*ops)[4].strength, 1.0);
    EXPECT_EQ((*ops)[5].strength, 0.25);
}

TEST(OpScript, errorsNameTheLineAndTheRule) {
    auto unknown = parseOpScript("crater 1 2 3 4\nexplode 1 2 3 4\n");
    ASSERT_FALSE(unknown.ok());
    EXPECT_NE(unknown.error().message.find("line 2"), std::string::npos);
    EXPECT_NE(unknown.error().message.find("explode"), std::string::npos);
    EXPECT_FALSE(parseOpScript("crater 1 2 3\n").ok());
    EXPECT_FALSE(parseOpScript("crater 1 2 3 4 5 6\n").ok());
    auto nan = parseOpScript("raise 1 2 x3 4\n");
    ASSERT_FALSE(nan.ok());
    EXPECT_NE(nan.error().message.find("x3"), std::string::npos);
}

TEST(OpScript, randomCratersAreReproducibleAndInsideTheMap) {
    WorldSpec spec;
    spec.width = 300;
    spec.height = 200;
    CraterSeries s;
    s.seed = 99;
    s.count = 500;
    const auto a = randomCraters(spec, s);
    const auto b = randomCraters(spec, s);
    ASSERT_EQ(a.size(), 500u);
    for (std::size_t i = 0; i < a.size(); ++i) {
        EXPECT_EQ(a[i].x, b[i].x);
        EXPECT_GE(a[i].x, 0.0);
        EXPECT_LE(a[i].x, spec.extentX());
        EXPECT_LE(a[i].y, spec.extentY());
        EXPECT_GE(a[i].radius, s.min_radius);
        EXPECT_LE(a[i].radius, s.max_radius);
    }
}

} // namespace
} // namespace terrain
