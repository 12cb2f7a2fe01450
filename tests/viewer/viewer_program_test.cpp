// terrain-viewer itself, under Xvfb (llvmpipe): a scripted flight over an in-process server with
// craters every 100 frames must end verified, with a screenshot that shows sky and terrain.
// Skipped when xvfb-run is not installed (apt-get install xvfb xauth).

#include "support/image_checks.h"

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <png.h>
#include <sys/wait.h>
#include <unistd.h>

#include <array>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>

namespace terrain {
namespace {

namespace fs = std::filesystem;

bool onPath(const std::string& program) {
    return std::system(("command -v " + program + " > /dev/null 2>&1").c_str()) == 0;
}

struct ProgramRun {
    int exit_code = -1;
    std::string output; ///< stdout and stderr
};

ProgramRun runCommand(const std::string& command) {
    ProgramRun run;
    FILE* pipe = popen((command + " 2>&1").c_str(), "r");
    if (pipe == nullptr)
        return run;
    std::array<char, 4096> buffer;
    while (std::fgets(buffer.data(), buffer.size(), pipe) != nullptr)
        run.output += buffer.data();
    const int status = pclose(pipe);
    run.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
    return run;
}

#if defined(__SANITIZE_ADDRESS__)
#define TERRAIN_TEST_UNDER_ASAN 1
#elif defined(__has_feature)
#if __has_feature(address_sanitizer)
#define TERRAIN_TEST_UNDER_ASAN 1
#endif
#endif

/// Under AddressSanitizer the test preloads Mesa's libglapi and swrast driver into the viewer so
/// they stay loaded to the end. Otherwise GLFW's glfwTerminate() unloads them while their globals
/// still point at what they allocated, and LeakSanitizer, which runs later, reports that memory
/// as leaked from "<unknown module>" (255 strdup'd GL function names in libglapi, two 56-byte
/// callocs in swrast_dri.so; a bare GLFW program shows the same). An unloaded module has no name
/// or frame a suppression could match; kept loaded, its globals are scanned and nothing of Mesa's
/// is reported. Nothing of ours is suppressed.
std::string leakCheckPrefix() {
#ifdef TERRAIN_TEST_UNDER_ASAN
    return "env LD_PRELOAD='" TERRAIN_MESA_PINS "' "
           "ASAN_OPTIONS=\"${ASAN_OPTIONS:+$ASAN_OPTIONS:}verify_asan_link_order=0\" ";
#else
    return "";
#endif
}

/// The viewer's path and `args`, for the shell. (Appending, not operator+: GCC 12 at -O3 warns
/// falsely about "literal" + string, -Wrestrict.)
std::string viewerCommand(const std::string& args) {
    std::string command = leakCheckPrefix();
    command += "'";
    command += TERRAIN_VIEWER_BIN;
    command += "' ";
    command += args;
    return command;
}

/// Runs the viewer with `args` in a fresh Xvfb display. The X authority file is ours (-f), so
/// xvfb-run makes no temporary directory: with two runs at once, removing that directory failed
/// now and then ("problem while cleaning up temporary directory", exit 5), which hid the
/// viewer's own exit code.
ProgramRun runViewer(const std::string& args) {
    const fs::path auth_dir = fs::path(TERRAIN_TEST_OUTPUT_DIR) / "viewer_xauth";
    fs::create_directories(auth_dir);
    std::string auth_file = (auth_dir / "Xauthority.XXXXXX").string();
    const int fd = mkstemp(auth_file.data());
    if (fd < 0)
        return ProgramRun{-1, "mkstemp failed for the X authority file " + auth_file};
    close(fd);
    std::string command = "xvfb-run -a -f '" + auth_file + "' -s '-screen 0 1280x1024x24' ";
    command += viewerCommand(args);
    ProgramRun run = runCommand(command);
    // two xvfb-run -a started at once can pick the same display number; the loser says so
    for (int retry = 0; retry < 3 && run.output.find("Xvfb failed to start") != std::string::npos;
         ++retry)
        run = runCommand(command);
    fs::remove(auth_file);
    return run;
}

/// Any PNG as 8-bit RGB (libpng's simplified API); empty on failure. shared/io reads gray only.
io::RgbImage readRgbPng(const fs::path& path) {
    png_image image{};
    image.version = PNG_IMAGE_VERSION;
    io::RgbImage out;
    if (!png_image_begin_read_from_file(&image, path.c_str()))
        return out;
    image.format = PNG_FORMAT_RGB;
    std::vector<std::uint8_t> rgb(PNG_IMAGE_SIZE(image));
    if (!png_image_finish_read(&image, nullptr, rgb.data(), 0, nullptr)) {
        png_image_free(&image);
        return out;
    }
    out.width = static_cast<std::int32_t>(image.width);
    out.height = static_cast<std::int32_t>(image.height);
    out.rgb = std::move(rgb);
    return out;
}

fs::path outputDir() {
    const fs::path dir = fs::path(TERRAIN_TEST_OUTPUT_DIR) / "viewer_out";
    fs::create_directories(dir);
    return dir;
}

TEST(ViewerProgram, FliesCratersAndEndsVerified) {
    if (!onPath("xvfb-run"))
        GTEST_SKIP() << "xvfb-run is not on PATH (apt-get install xvfb xauth): the viewer needs "
                        "an X server";
    const fs::path png = outputDir() / "viewer_last_frame.png";
    const fs::path report_path = outputDir() / "viewer_report.json";
    fs::remove(png);
    fs::remove(report_path);

    const ProgramRun run = runViewer(
        "--size 257 --width 640 --height 400 --frames 300 --fly --auto-crater 100 --screenshot '" +
        png.string() + "' --report '" + report_path.string() + "'");
    ASSERT_EQ(run.exit_code, 0) << run.output;

    // the last frame: a real picture, sky above and terrain below
    const io::RgbImage image = readRgbPng(png);
    ASSERT_EQ(image.width, 640) << png;
    ASSERT_EQ(image.height, 400);
    EXPECT_GT(testing::distinctColours(image), 1000);
    int sky = 0;
    int ground = 0;
    for (std::size_t i = 0; i + 2 < image.rgb.size(); i += 3) {
        const int r = image.rgb[i];
        const int g = image.rgb[i + 1];
        const int b = image.rgb[i + 2];
        // the renderer's sky is (0.62, 0.74, 0.88); terrain is shaded earth and rock
        if (b > 180 && b > r + 30 && b > g + 10)
            ++sky;
        else
            ++ground;
    }
    const int pixels = image.width * image.height;
    EXPECT_GT(sky, pixels / 10) << "too little sky: the camera should look across the map";
    EXPECT_GT(ground, pixels / 4) << "too little terrain";

    // the report: every frame drawn, craters made, the replica on the server's state
    std::ifstream in(report_path);
    ASSERT_TRUE(in.good()) << report_path << "\n" << run.output;
    const nlohmann::json report = nlohmann::json::parse(in);
    EXPECT_EQ(report.at("frames").get<int>(), 300);
    EXPECT_GE(report.at("craters_accepted").get<int>(), 1);
    EXPECT_EQ(report.at("craters_refused").get<int>(), 0);
    EXPECT_GE(report.at("seq").get<int>(), 1);
    EXPECT_EQ(report.at("hash_mismatches").get<int>(), 0);
    EXPECT_TRUE(report.at("synced").get<bool>());
    EXPECT_FALSE(report.at("diverged").get<bool>());
    EXPECT_EQ(report.at("server_seq"), report.at("seq"));
    EXPECT_EQ(report.at("server_world_hash"), report.at("world_hash"));
    EXPECT_GT(report.at("triangles").get<int>(), 0);
    EXPECT_GT(report.at("bytes_uploaded").get<std::uint64_t>(), 0u);
}

TEST(ViewerProgram, GeomorphingDrawsTheFlight) {
    if (!onPath("xvfb-run"))
        GTEST_SKIP() << "xvfb-run is not on PATH (apt-get install xvfb xauth)";
    const fs::path png = outputDir() / "viewer_geomorph.png";
    const fs::path report_path = outputDir() / "viewer_geomorph.json";
    fs::remove(png);
    fs::remove(report_path);
    const ProgramRun run = runViewer(
        "--size 257 --width 320 --height 200 --frames 60 --fly --geomorph 0.5 --screenshot '" +
        png.string() + "' --report '" + report_path.string() + "'");
    ASSERT_EQ(run.exit_code, 0) << run.output;
    const io::RgbImage image = readRgbPng(png);
    ASSERT_EQ(image.width, 320) << png;
    EXPECT_GT(testing::distinctColours(image), 500);
    std::ifstream in(report_path);
    ASSERT_TRUE(in.good()) << report_path << "\n" << run.output;
    const nlohmann::json report = nlohmann::json::parse(in);
    EXPECT_EQ(report.at("frames").get<int>(), 60);
    EXPECT_GT(report.at("triangles").get<int>(), 0);
    EXPECT_TRUE(report.at("synced").get<bool>());
}

TEST(ViewerProgram, NamesTheServerItCannotJoin) {
    if (!onPath("xvfb-run"))
        GTEST_SKIP() << "xvfb-run is not on PATH (apt-get install xvfb xauth)";
    // port 1 on loopback: nothing listens there
    const ProgramRun run =
        runViewer("--connect 127.0.0.1:1 --token x --join-timeout 1 --frames 10");
    EXPECT_EQ(run.exit_code, 1) << run.output;
    EXPECT_EQ(run.output.find("LeakSanitizer"), std::string::npos) << run.output; // also exits 1
    EXPECT_NE(run.output.find("could not join 127.0.0.1:1 within 1 s"), std::string::npos)
        << run.output;
}

TEST(ViewerProgram, RefusesBadOptionsByRule) {
    // options are checked before any window opens: no X server needed
    const ProgramRun run = runCommand(viewerCommand("--tau 0"));
    EXPECT_EQ(run.exit_code, 2) << run.output;
    EXPECT_NE(run.output.find("--tau must be > 0"), std::string::npos) << run.output;
}

} // namespace
} // namespace terrain
