#include <terrain/io/dem_import.h>
#include <terrain/io/png_image.h>
#include <terrain/io/shaded_relief.h>
#include <terrain/surface_query.h>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <png.h>
#include <zlib.h>

#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>

namespace terrain::io {
namespace {

namespace fs = std::filesystem;

const fs::path kDemDir = TERRAIN_DEM_DIR;

#define REQUIRE_DEM(name)                                                                          \
    if (!fs::exists(kDemDir / name))                                                               \
    GTEST_SKIP() << "reference DEM " << (kDemDir / name) << " is absent (../shared/data/dem)"

std::vector<std::uint8_t> int16Raw(const std::vector<std::int16_t>& v) {
    std::vector<std::uint8_t> out;
    for (std::int16_t s : v) {
        out.push_back(static_cast<std::uint8_t>(s & 0xff));
        out.push_back(static_cast<std::uint8_t>((s >> 8) & 0xff));
    }
    return out;
}

std::vector<std::uint8_t> floatRaw(const std::vector<float>& v) {
    std::vector<std::uint8_t> out(v.size() * 4);
    std::memcpy(out.data(), v.data(), out.size()); // the test host is little-endian like the format
    return out;
}

const char* kSidecar3x2 = R"({"width": 3, "height": 2, "sample_type": "int16",
    "byte_order": "little-endian", "nodata": -32768, "vertical_scale": 1.0,
    "horizontal": {"spacing_m": {"x": 30.0, "y": 30.0}}})";

TEST(DemImport, readsInt16AndTakesSpacingFromTheSidecar) {
    auto dem = importDemFromMemory(kSidecar3x2, int16Raw({100, 101, 102, 200, 201, 202}), {});
    ASSERT_TRUE(dem.ok()) << dem.error().message;
    EXPECT_EQ(dem->terrain.spec().width, 3);
    EXPECT_EQ(dem->terrain.spec().spacing, 30 * 1024);
    EXPECT_EQ(dem->info.spacing_source, "horizontal.spacing_m");
    EXPECT_EQ(dem->info.resampling, "");
    // row 0 of the file is north: the terrain's y points north, so it is the last row
    EXPECT_EQ(dem->terrain.sample(2, 1), 102 * 1024);
    EXPECT_EQ(dem->terrain.sample(0, 0), 200 * 1024);
    EXPECT_EQ(dem->terrain.sample(0, 1), 100 * 1024);
}

TEST(DemImport, fillsNodataWithTheLowestValidSampleAndCountsIt) {
    auto dem = importDemFromMemory(kSidecar3x2, int16Raw({100, -32768, 102, 200, 201, 90}), {});
    ASSERT_TRUE(dem.ok());
    EXPECT_EQ(dem->info.nodata_filled, 1);
    EXPECT_EQ(dem->terrain.sample(1, 1), 90 * 1024);
}

// Cells of 1 x 2 m become 1 x 1: three rows become five, each new one on the source's linear
// profile, the source rows kept where they fall on new ones, and the error where a peak falls
// between new rows measured.
TEST(DemImport, nonSquareCellsAreResampledAlongTheCoarserAxis) {
    const char* json = R"({"width": 2, "height": 3, "sample_type": "int16",
        "horizontal": {"approx_spacing_m": {"x": 1.0, "y": 2.0}}})";
    // north row first: 8 8 / 4 6 / 0 0
    auto dem = importDemFromMemory(json, int16Raw({8, 8, 4, 6, 0, 0}), {});
    ASSERT_TRUE(dem.ok()) << dem.error().message;
    EXPECT_EQ(dem->info.width, 2);
    EXPECT_EQ(dem->info.height, 5);
    EXPECT_DOUBLE_EQ(dem->info.spacing_metres, 1.0);
    EXPECT_EQ(dem->info.resampling, "rows: 3 at 2.000000 m -> 5 at 1.000000 m, linear along y");
    const std::int32_t column0[] = {0, 2, 4, 6, 8};
    const std::int32_t column1[] = {0, 3, 6, 7, 8};
    for (std::int32_t y = 0; y < 5; ++y) {
        EXPECT_EQ(dem->terrain.sample(0, y), column0[y] * 1024) << y;
        EXPECT_EQ(dem->terrain.sample(1, y), column1[y] * 1024) << y;
    }
    EXPECT_EQ(dem->info.resample_max_error_metres, 0.0); // every source row is a new row

    // 2 m -> 1.5 m: the middle source row (a ridge of 9) falls between new rows 1 and 2
    const char* coarse = R"({"width": 2, "height": 3, "sample_type": "int16",
        "horizontal": {"approx_spacing_m": {"x": 1.5, "y": 2.0}}})";
    auto ridge = importDemFromMemory(coarse, int16Raw({0, 0, 9, 9, 0, 0}), {});
    ASSERT_TRUE(ridge.ok()) << ridge.error().message;
    EXPECT_EQ(ridge->info.height, 4); // 4 m / 1.5 m = 2.67 cells, rounded to 3
    // new rows at 0, 1.5, 3, 4.5 m read 0, 6.75, 4.5, 0 (4.5 m clamps to the last source row);
    // the surface at the ridge (2 m) is 6.75 - 2.25 / 3 = 6: 3 m low
    EXPECT_EQ(ridge->terrain.sample(0, 1), 7 * 1024 - 256);
    EXPECT_NEAR(ridge->info.resample_max_error_metres, 9.0 - (6.75 - (6.75 - 4.5) / 3.0), 1e-3);
}

TEST(DemImport, readsFloat32AndRefusesNonFiniteSamples) {
    const char* json = R"({"width": 2, "height": 2, "sample_type": "float32",
        "horizontal": {"approx_spacing_m": {"x": 10.5}}})";
    auto dem = importDemFromMemory(json, floatRaw({1.5f, 2.25f, -3.0f, 4.0f}), {});
    ASSERT_TRUE(dem.ok()) << dem.error().message;
    EXPECT_EQ(dem->terrain.sample(1, 1), 2304);
    EXPECT_EQ(dem->info.spacing_source, "horizontal.approx_spacing_m");
    auto nan = importDemFromMemory(json, floatRaw({1.5f, NAN, -3.0f, 4.0f}), {});
    ASSERT_FALSE(nan.ok());
    EXPECT_EQ(nan.error().code, ErrorCode::kNotFinite);
    auto inf = importDemFromMemory(json, floatRaw({1.5f, 2.f, INFINITY, 4.0f}), {});
    EXPECT_EQ(inf.error().code, ErrorCode::kNotFinite);
    auto huge = importDemFromMemory(json, floatRaw({1.5f, 2.f, 3e30f, 4.0f}), {});
    EXPECT_EQ(huge.error().code, ErrorCode::kOutOfRange);
}

TEST(DemImport, refusesTruncatedOrMissizedRawFiles) {
    const auto raw = int16Raw({100, 101, 102, 200, 201, 202});
    for (std::size_t n : {std::size_t{0}, std::size_t{1}, std::size_t{11}}) {
        auto dem = importDemFromMemory(kSidecar3x2, std::span(raw.data(), n), {});
        ASSERT_FALSE(dem.ok());
        EXPECT_EQ(dem.error().code, ErrorCode::kSizeMismatch);
        EXPECT_NE(dem.error().message.find("needs 12"), std::string::npos) << dem.error().message;
    }
    auto longer = raw;
    longer.push_back(0);
    longer.push_back(0);
    EXPECT_EQ(importDemFromMemory(kSidecar3x2, longer, {}).error().code, ErrorCode::kSizeMismatch);
}

TEST(DemImport, refusesWrongJsonWithTheFieldNamed) {
    const auto raw = int16Raw({1, 2, 3, 4});
    struct Case {
        const char* json;
        ErrorCode code;
        const char* says;
    } cases[] = {
        {"{not json", ErrorCode::kBadFormat, "JSON"},
        {"[1, 2]", ErrorCode::kBadFormat, "object"},
        {R"({"height": 2, "sample_type": "int16"})", ErrorCode::kBadFormat, "width"},
        {R"({"width": "2", "height": 2, "sample_type": "int16"})", ErrorCode::kBadFormat, "width"},
        {R"({"width": 2.5, "height": 2, "sample_type": "int16"})", ErrorCode::kBadFormat, "width"},
        {R"({"width": 1, "height": 2, "sample_type": "int16"})", ErrorCode::kOutOfRange, "width"},
        {R"({"width": -4, "height": 2, "sample_type": "int16"})", ErrorCode::kOutOfRange, "width"},
        {R"({"width": 2, "height": 2, "sample_type": "uint8"})", ErrorCode::kUnsupported, "uint8"},
        {R"({"width": 2, "height": 2, "sample_type": 16})", ErrorCode::kBadFormat, "sample_type"},
        {R"({"width": 2, "height": 2, "sample_type": "int16", "byte_order": "big-endian"})",
         ErrorCode::kBadFormat, "byte_order"},
        {R"({"width": 2, "height": 2, "sample_type": "int16"})", ErrorCode::kBadFormat, "spacing"},
        {R"({"width": 2, "height": 2, "sample_type": "int16", "vertical_scale": -1,
             "horizontal": {"spacing_m": {"x": 1}}})",
         ErrorCode::kOutOfRange, "vertical scale"},
        {R"({"width": 2, "height": 2, "sample_type": "int16", "nodata": "none",
             "horizontal": {"spacing_m": {"x": 1}}})",
         ErrorCode::kBadFormat, "nodata"},
    };
    for (const Case& c : cases) {
        auto dem = importDemFromMemory(c.json, raw, {});
        ASSERT_FALSE(dem.ok()) << c.json;
        EXPECT_EQ(dem.error().code, c.code) << c.json << " -> " << dem.error().message;
        EXPECT_NE(dem.error().message.find(c.says), std::string::npos) << dem.error().message;
    }
}

TEST(DemImport, fileImportRefusesPathsOutsideTheSidecarFolderAndMissingFiles) {
    const fs::path dir = fs::temp_directory_path() / "terrain_dem_import_test";
    fs::create_directories(dir);
    std::ofstream(dir / "evil.json")
        << R"({"file": "../etc/passwd", "width": 2, "height": 2, "sample_type": "int16"})";
    auto evil = importDem(dir / "evil.json", {});
    ASSERT_FALSE(evil.ok());
    EXPECT_NE(evil.error().message.find("file"), std::string::npos);
    auto missing = importDem(dir / "nothing.json", {});
    EXPECT_EQ(missing.error().code, ErrorCode::kIo);
    fs::remove_all(dir);
}

TEST(DemImport, srtmTileMatchesItsSidecar) {
    REQUIRE_DEM("srtm_n44w072");
    auto dem = importDem(kDemDir / "srtm_n44w072", {});
    ASSERT_TRUE(dem.ok()) << dem.error().message;
    // 3" cells are 66.2 m east-west and 92.8 m north-south here: the 1200 north-south cells
    // become 1682 of 66.2 m, so the map is not squeezed by 29 %
    EXPECT_EQ(dem->info.source_width, 1201);
    EXPECT_EQ(dem->info.source_height, 1201);
    EXPECT_EQ(dem->info.width, 1201);
    EXPECT_EQ(dem->info.height, 1683);
    EXPECT_NEAR(dem->info.spacing_metres, 66.2, 1e-9);
    EXPECT_NE(dem->info.resampling.find("linear along y"), std::string::npos);
    EXPECT_NEAR(dem->terrain.spec().extentY(), 1200 * 92.8, 0.5 * 66.2);
    EXPECT_EQ(dem->info.nodata_filled, 0);
    EXPECT_GE(dem->info.min_metres, 115.0);
    EXPECT_LE(dem->info.max_metres, 1908.0);
    // Mt Washington (1917 m; the grid holds 1908 at its sample, row 875, col 836 from the
    // north-west corner: 44.2708 N, 71.3033 W): at that place, on the resampled grid
    const double metres = dem->terrain.spec().spacingMetres() / 66.2; // quantised cells
    const double x = 836 * 66.2 * metres;
    const double y = (1200 - 875) * 92.8 * metres;
    const double summit = surfaceHeight(dem->terrain, x, y);
    EXPECT_NEAR(summit, 1908.0, dem->info.resample_max_error_metres + 1e-3);
    EXPECT_GT(summit, 1880.0);
    // and it is the highest point within a kilometre
    for (double dx = -1000.0; dx <= 1000.0; dx += 50.0)
        for (double dy = -1000.0; dy <= 1000.0; dy += 50.0)
            EXPECT_LE(surfaceHeight(dem->terrain, x + dx, y + dy), 1908.0 + 1e-3);
}

// Every reference DEM keeps its true extent (x east, y north) within half a cell, its stated
// value range, and the height of every source sample within the importer's stated resampling
// error, read back through the surface at the sample's own place.
TEST(DemImport, everyReferenceDemKeepsItsExtentAndItsHeights) {
    REQUIRE_DEM("srtm_n44w072");
    for (const auto& entry : fs::directory_iterator(kDemDir)) {
        if (!entry.is_directory())
            continue;
        const std::string name = entry.path().filename().string();
        std::ifstream in(entry.path() / (name + ".json"));
        const auto side = nlohmann::json::parse(in, nullptr, false);
        ASSERT_FALSE(side.is_discarded()) << name;
        const auto& hz = side["horizontal"];
        double sx = 40.0; // gcanyon states no spacing; its notes suggest 30-45 m
        double sy = 40.0;
        DemImportOptions o;
        if (hz.contains("spacing_m") && hz["spacing_m"].is_object()) {
            sx = hz["spacing_m"]["x"].get<double>();
            sy = hz["spacing_m"]["y"].get<double>();
        } else if (hz.contains("approx_spacing_m")) {
            sx = hz["approx_spacing_m"]["x"].get<double>();
            sy = hz["approx_spacing_m"]["y"].get<double>();
        } else {
            o.spacing_metres = sx;
        }
        auto dem = importDem(entry.path(), o);
        ASSERT_TRUE(dem.ok()) << name << ": " << dem.error().message;
        const DemInfo& info = dem->info;
        const std::int32_t w = side["width"].get<std::int32_t>();
        const std::int32_t h = side["height"].get<std::int32_t>();
        const double cell = info.spacing_metres;
        EXPECT_DOUBLE_EQ(cell, std::min(sx, sy)) << name;
        EXPECT_NEAR(dem->terrain.spec().extentX(), (w - 1) * sx, 0.5 * cell) << name;
        EXPECT_NEAR(dem->terrain.spec().extentY(), (h - 1) * sy, 0.5 * cell) << name;
        EXPECT_EQ(info.resampling.empty(), sx == sy) << name;
        const double scale = info.vertical_scale;
        const double lo = side["stats"]["min"].get<double>() * scale;
        const double hi = side["stats"]["max"].get<double>() * scale;
        EXPECT_GE(info.min_metres, lo - 1e-6) << name;
        EXPECT_LE(info.max_metres, hi + 1e-6) << name;
        EXPECT_NEAR(info.max_metres, hi, info.resample_max_error_metres + 1e-3) << name;
        EXPECT_NEAR(info.min_metres, lo, info.resample_max_error_metres + 1e-3) << name;
        // a resampled axis cuts peaks between its rows, but not by more than the relief
        // changes across one source cell
        EXPECT_LT(info.resample_max_error_metres, sx == sy ? 1.0 / 1024 : 0.2 * (hi - lo)) << name;
        // every source sample, read back where it lies
        std::ifstream raw(entry.path() / side["file"].get<std::string>(), std::ios::binary);
        const bool f32 = side["sample_type"] == "float32";
        std::vector<char> bytes((std::istreambuf_iterator<char>(raw)), {});
        double worst = 0.0;
        for (std::int32_t r = 0; r < h; ++r) {
            for (std::int32_t c = 0; c < w; ++c) {
                const std::size_t i = static_cast<std::size_t>(r) * w + c;
                double v = 0.0;
                if (f32) {
                    float f = 0.0f;
                    std::memcpy(&f, bytes.data() + 4 * i, 4);
                    v = f;
                } else {
                    std::int16_t s = 0;
                    std::memcpy(&s, bytes.data() + 2 * i, 2);
                    v = s;
                }
                // where the sample lies in the terrain's frame (its spacing is whole quanta)
                const double at = surfaceHeight(
                    dem->terrain, c * sx / cell * dem->terrain.spec().spacingMetres(),
                    (h - 1 - r) * sy / cell * dem->terrain.spec().spacingMetres());
                worst = std::max(worst, std::abs(at - v * scale));
            }
        }
        EXPECT_LE(worst, info.resample_max_error_metres + 1e-6) << name;
        std::printf(
            "%-20s %4d x %4d -> %4d x %4d, %.1f m cells, extent %.0f x %.0f m, "
            "resampling error max %.3f m, mean %.3f m\n",
            name.c_str(), w, h, info.width, info.height, cell, dem->terrain.spec().extentX(),
            dem->terrain.spec().extentY(), info.resample_max_error_metres,
            info.resample_mean_error_metres);
    }
}

TEST(DemImport, everyReferenceDemImportsWithItsStatedSize) {
    REQUIRE_DEM("st_helens_usgs_1980");
    struct Expect {
        const char* name;
        int w, h;
        std::optional<double> spacing;
    } expects[] = {
        {"st_helens_usgs_1980", 317, 460, std::nullopt},
        {"jacksboro_fault", 403, 344, std::nullopt},
        {"msh_crater_2000", 303, 442, std::nullopt},
        {"msh_crater_2007", 303, 442, std::nullopt},
        {"gcanyon_hoppe_1200", 1200, 1200, 40.0}, // the source states no spacing
    };
    for (const Expect& e : expects) {
        DemImportOptions o;
        o.spacing_metres = e.spacing;
        auto dem = importDem(kDemDir / e.name, o);
        ASSERT_TRUE(dem.ok()) << e.name << ": " << dem.error().message;
        EXPECT_EQ(dem->info.source_width, e.w);
        EXPECT_EQ(dem->info.source_height, e.h);
    }
    auto canyon = importDem(kDemDir / "gcanyon_hoppe_1200", {});
    ASSERT_FALSE(canyon.ok());
    EXPECT_NE(canyon.error().message.find("spacing"), std::string::npos);
}

TEST(PngImport, reads16BitGrayscaleValuesExactly) {
    const fs::path path = fs::temp_directory_path() / "terrain_png16_test.png";
    const int w = 5;
    const int h = 4;
    std::vector<std::uint16_t> values(w * h);
    for (int i = 0; i < w * h; ++i)
        values[i] = static_cast<std::uint16_t>(i * 3001);
    // write with libpng directly: 16-bit gray, big-endian samples
    {
        FILE* f = std::fopen(path.c_str(), "wb");
        ASSERT_NE(f, nullptr);
        png_structp png = png_create_write_struct(PNG_LIBPNG_VER_STRING, nullptr, nullptr, nullptr);
        png_infop info = png_create_info_struct(png);
        png_init_io(png, f);
        png_set_IHDR(
            png, info, w, h, 16, PNG_COLOR_TYPE_GRAY, PNG_INTERLACE_NONE,
            PNG_COMPRESSION_TYPE_DEFAULT, PNG_FILTER_TYPE_DEFAULT);
        png_write_info(png, info);
        std::vector<std::uint8_t> row(w * 2);
        for (int y = 0; y < h; ++y) {
            for (int x = 0; x < w; ++x) {
                row[2 * x] = static_cast<std::uint8_t>(values[y * w + x] >> 8);
                row[2 * x + 1] = static_cast<std::uint8_t>(values[y * w + x] & 0xff);
            }
            png_write_row(png, row.data());
        }
        png_write_end(png, nullptr);
        png_destroy_write_struct(&png, &info);
        std::fclose(f);
    }
    auto dem = importPng(path, 2.0, 0.01, -100.0, {});
    ASSERT_TRUE(dem.ok()) << dem.error().message;
    for (int i = 0; i < w * h; ++i)
        EXPECT_EQ(
            dem->terrain.sample(i % w, h - 1 - i / w),
            std::lround((-100.0 + values[i] * 0.01) * 1024))
            << "the image's top row is north, the terrain's last";
    fs::remove(path);

    const fs::path junk = fs::temp_directory_path() / "terrain_not_a_png.png";
    std::ofstream(junk) << "definitely not a png";
    EXPECT_EQ(importPng(junk, 1.0, 1.0, 0.0, {}).error().code, ErrorCode::kBadFormat);
    fs::remove(junk);
}

// A 100-byte file that declares a 32768 x 32768 16-bit image must be refused without
// allocating gigabytes: by the pixel budget, or as truncated when the budget allows it.
TEST(PngImport, sizeBombsAreRefusedCheaply) {
    auto chunk = [](std::vector<std::uint8_t>& out, const char* type,
                    std::vector<std::uint8_t> data) {
        const auto n = static_cast<std::uint32_t>(data.size());
        for (int s = 24; s >= 0; s -= 8)
            out.push_back(static_cast<std::uint8_t>(n >> s));
        std::vector<std::uint8_t> body(type, type + 4);
        body.insert(body.end(), data.begin(), data.end());
        out.insert(out.end(), body.begin(), body.end());
        const auto crc =
            static_cast<std::uint32_t>(crc32(0, body.data(), static_cast<uInt>(body.size())));
        for (int s = 24; s >= 0; s -= 8)
            out.push_back(static_cast<std::uint8_t>(crc >> s));
    };
    std::vector<std::uint8_t> png = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'};
    chunk(png, "IHDR", {0, 0, 0x80, 0, 0, 0, 0x80, 0, 16, 0, 0, 0, 0});
    // a valid zlib stream of a few zero bytes: one filter byte and the start of a row
    std::vector<std::uint8_t> raw(64, 0);
    std::vector<std::uint8_t> z(128);
    uLongf zlen = z.size();
    ASSERT_EQ(compress(z.data(), &zlen, raw.data(), raw.size()), Z_OK);
    z.resize(zlen);
    chunk(png, "IDAT", z);
    chunk(png, "IEND", {});
    const fs::path path = fs::temp_directory_path() / "terrain_png_bomb.png";
    std::ofstream(path, std::ios::binary)
        .write(reinterpret_cast<const char*>(png.data()), png.size());
    auto budget = readGrayPng(path);
    ASSERT_FALSE(budget.ok());
    EXPECT_EQ(budget.error().code, ErrorCode::kOutOfRange);
    EXPECT_NE(budget.error().message.find("budget"), std::string::npos);
    auto truncated = readGrayPng(path, std::uint64_t{1} << 31);
    ASSERT_FALSE(truncated.ok());
    EXPECT_EQ(truncated.error().code, ErrorCode::kBadFormat) << truncated.error().message;
    fs::remove(path);
}

TEST(DemImport, gridsBeyondTheSampleBudgetAreRefusedBeforeReading) {
    DemImportOptions o;
    o.max_samples = 100;
    auto dem = importDemFromMemory(kSidecar3x2, int16Raw({1, 2, 3, 4, 5, 6}), o);
    ASSERT_TRUE(dem.ok());
    o.max_samples = 5;
    auto refused = importDemFromMemory(kSidecar3x2, int16Raw({1, 2, 3, 4, 5, 6}), o);
    ASSERT_FALSE(refused.ok());
    EXPECT_EQ(refused.error().code, ErrorCode::kOutOfRange);
    EXPECT_NE(refused.error().message.find("budget"), std::string::npos);
}

TEST(ShadedRelief, writesAnImageWhoseShadingFollowsTheSlope) {
    auto dem = importDemFromMemory(
        R"({"width": 3, "height": 3, "sample_type": "int16", "horizontal": {"spacing_m": {"x": 1}}})",
        int16Raw({0, 0, 0, 0, 0, 0, 0, 0, 0}), {});
    ASSERT_TRUE(dem.ok());
    ReliefOptions o;
    o.pixels_per_cell = 4;
    const RgbImage img = renderShadedRelief(dem->terrain, o);
    EXPECT_EQ(img.width, 9);
    EXPECT_EQ(img.height, 9);
    // flat ground: every pixel the same
    for (std::size_t i = 3; i < img.rgb.size(); ++i)
        EXPECT_EQ(img.rgb[i], img.rgb[i % 3]);
    const fs::path out = fs::temp_directory_path() / "terrain_relief_test.png";
    ASSERT_TRUE(writeRgbPng(out, img).ok());
    EXPECT_GT(fs::file_size(out), 20u);
    fs::remove(out);
}

} // namespace
} // namespace terrain::io
