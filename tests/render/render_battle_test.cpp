// A battle through the renderer, driven the way a game's frame loop on a GPU drives it, and
// checked for what went wrong on one (holes after craters, buffers that drifted from the mesh):
// - view-aimed craters (lodlab's battle generator, at the battle zone) while the camera crosses
//   the zone low (lodlab's battle flight) and looks back over its shoulder every 30 frames for
//   10, so that tiles behind are evicted (after 4 frames out of view) and reloaded;
// - the ops' timing of a fast frame loop: long quiet stretches, single ops, bursts of up to 12
//   in one frame, and ops that arrive after the tessellation and before its upload;
// - checked: after every sync the renderer's buffers, read back, equal a fresh build from the
//   tessellator (RendererOptions::validate); on every 10th frame and every frame a burst or an
//   op between tessellation and upload arrived in, the picture drawn from the incrementally
//   updated buffers equals, pixel for pixel, the same mesh drawn by a renderer built fresh, and
//   shows no sky below the horizon; the driver reported no error (KHR_debug).
// Both upload paths (persistent mapping, GL 3.3 map-range) on OSMesa here; with
// TERRAIN_TEST_GL=egl the same runs through EGL (a GPU machine's driver).

#include "support/image_checks.h"
#include "support/render_scene.h"
#include "support/terrain_builders.h"

#include <terrain/lodlab/flights.h>
#include <terrain/render/gpu_timer.h>
#include <terrain/render/sky_holes.h>
#include <terrain/surface_query.h>

#include <gtest/gtest.h>

#include <array>
#include <chrono>
#include <cstdlib>
#include <cstring>
#include <string>

namespace terrain {
namespace {

constexpr int kBattleWidth = 480;
constexpr int kBattleHeight = 320;

render::OffscreenBackend testBackend() {
    const char* gl = std::getenv("TERRAIN_TEST_GL");
    return gl != nullptr && std::strcmp(gl, "egl") == 0 ? render::OffscreenBackend::kEgl
                                                        : render::OffscreenBackend::kOsmesa;
}

std::uint64_t mix(std::uint64_t x) {
    x ^= x >> 33;
    x *= 0xff51afd7ed558ccdull;
    x ^= x >> 33;
    x *= 0xc4ceb9fe1a85ec53ull;
    return x ^ (x >> 33);
}

/// When ops land in frame f: mostly quiet, then single ops, bursts, and ops between the
/// tessellation and the upload.
struct FrameOps {
    int before_update = 0;
    int before_sync = 0;
};
FrameOps opsOf(int f) {
    const std::uint64_t h = mix(static_cast<std::uint64_t>(f) + 77);
    const int roll = static_cast<int>(h % 20);
    const int burst = 4 + static_cast<int>((h >> 8) % 9);
    const int between = 1 + static_cast<int>((h >> 16) % 3);
    FrameOps o;
    if (roll >= 12 && roll <= 14)
        o.before_update = 1;
    else if (roll == 15 || roll == 16)
        o.before_update = burst;
    else if (roll == 17)
        o.before_sync = between;
    else if (roll == 18)
        o = {burst, between};
    return o;
}

/// 160 frames (243 craters) on the persistent path; the map-range path, which differs only in
/// how bytes reach the ring, and sanitizer builds (5 times slower) fly half as far.
int battleFrames(render::UploadPath path) {
    int frames = path == render::UploadPath::kPersistent ? 160 : 80;
#if defined(__SANITIZE_ADDRESS__)
    frames /= 2;
#endif
    return frames;
}

class RenderBattle : public ::testing::TestWithParam<render::UploadPath> {};

TEST_P(RenderBattle, IncrementalBuffersDrawWhatFreshBuffersDrawWithoutHoles) {
    Terrain t = testing::makeHills(21, 385, 385, 1.0);
    render::RendererOptions options = testing::RenderScene::validating();
    options.upload = GetParam();
    testing::RenderScene scene(t, 1.0, kBattleWidth, kBattleHeight, testBackend(), options);
    ASSERT_TRUE(scene.ok());
    // the path asked for is the path taken (llvmpipe has buffer storage)
    ASSERT_EQ(scene.renderer->uploadPath(), GetParam());
    scene.renderer->setEvictAfterFrames(4);

    lodlab::FlightOptions fo;
    fo.kind = lodlab::FlightKind::kBattle;
    fo.frames = battleFrames(GetParam());
    fo.width = kBattleWidth;
    fo.height = kBattleHeight;
    fo.seed = 3;
    const std::vector<lodlab::FlightFrame> flight = lodlab::makeFlight(t, fo);
    BattleGenerator shots = lodlab::battleGenerator(t);

    int craters = 0;
    std::vector<CellRect> cells;
    const auto fire = [&](int n) {
        cells.clear();
        for (int k = 0; k < n; ++k) {
            const BattleShot shot = shots.next(t);
            if (!shot.crater)
                continue;
            auto op = quantizeOp(*shot.crater, t.spec());
            if (!op)
                continue;
            auto effect = t.apply(*op);
            if (!effect)
                continue;
            cells.push_back(effect->cells);
            ++craters;
        }
        if (cells.empty())
            return;
        scene.tess->terrainChanged(cells, false);
    };

    const render::RenderOptions draw_options;
    int checked = 0;
    int evicting_frames = 0;
    std::int64_t holes = 0;
    std::int64_t differing = 0;
    std::string first_difference;
    for (int f = 0; f < fo.frames; ++f) {
        roam::Camera camera = flight[static_cast<std::size_t>(f)].camera;
        if (f % 30 >= 20)
            camera.forward = -camera.forward; // over the shoulder
        const FrameOps ops = opsOf(f);
        fire(ops.before_update);
        scene.tess->update(camera);
        fire(ops.before_sync);
        const render::UploadStats up = scene.renderer->sync(*scene.tess, t);
        evicting_frames += up.evicted_tiles > 0 ? 1 : 0;
        scene.renderer->draw(*scene.tess, camera, draw_options);
        scene.context->present();
        if (f % 10 != 0 && ops.before_sync == 0 && ops.before_update < 4)
            continue;
        ++checked;
        const io::RgbImage incremental = scene.context->readPixels();
        const render::SkyHoles h = render::countSkyHoles(incremental, draw_options.sky);
        holes += h.count;
        if (h.count > 0 && holes == h.count)
            ADD_FAILURE() << "frame " << f << ": " << h.count << " sky pixels below the horizon, "
                          << "the first at (" << h.first[0].x << ", " << h.first[0].y << ")";
        auto fresh = render::TerrainRenderer::create(*scene.context);
        ASSERT_TRUE(fresh.ok());
        (*fresh)->sync(*scene.tess, t);
        (*fresh)->draw(*scene.tess, camera, draw_options);
        const io::RgbImage rebuilt = scene.context->readPixels();
        const std::int64_t n = testing::countDiffering(incremental, rebuilt, 0).differing;
        if (n > 0 && first_difference.empty()) {
            first_difference = "frame " + std::to_string(f) + ": " + std::to_string(n) + " pixels";
            (void)io::writeRgbPng(
                std::filesystem::path(TERRAIN_TEST_OUTPUT_DIR) / "battle_incremental.png",
                incremental);
            (void)io::writeRgbPng(
                std::filesystem::path(TERRAIN_TEST_OUTPUT_DIR) / "battle_fresh.png", rebuilt);
        }
        differing += n;
    }
    const render::ValidationReport& v = scene.renderer->validation();
    std::printf(
        "%s: %d craters, %d frames checked, %llu syncs validated (%llu vertices, %llu indices), "
        "%d frames evicting, %llu tiles loaded, %llu buffers grown, %llu GPU copies\n",
        render::toString(GetParam()), craters, checked, static_cast<unsigned long long>(v.syncs),
        static_cast<unsigned long long>(v.vertices), static_cast<unsigned long long>(v.indices),
        evicting_frames, static_cast<unsigned long long>(scene.renderer->totals().loaded_tiles),
        static_cast<unsigned long long>(scene.renderer->totals().grown_buffers),
        static_cast<unsigned long long>(scene.renderer->ringStats().copies));
    EXPECT_GE(craters, fo.frames); // 200 and more in the full run
    EXPECT_GT(evicting_frames, 2) << "tiles must be evicted and reloaded";
    EXPECT_GT(scene.renderer->totals().grown_buffers, 0u) << "buffers must outgrow themselves";
    EXPECT_EQ(differing, 0) << first_difference;
    EXPECT_EQ(holes, 0);
    scene.expectClean();
}

INSTANTIATE_TEST_SUITE_P(
    Paths,
    RenderBattle,
    ::testing::Values(render::UploadPath::kPersistent, render::UploadPath::kMapRange),
    [](const auto& p) {
        return std::string(p.param == render::UploadPath::kPersistent ? "persistent" : "map_range");
    });

// The debug context reports what the driver refuses: a call it rejects shows as an error in the
// log (so the tests' "no GL errors" can fail).
TEST(RenderValidation, TheDebugLogCountsADriverError) {
    render::ContextOptions co;
    co.debug = true;
    auto context = render::createOffscreenContext(testBackend(), 64, 64, co);
    ASSERT_TRUE(context.ok()) << context.error().message;
    render::GlDebugLog* log = (*context)->debugLog();
    ASSERT_NE(log, nullptr) << "no KHR_debug";
    std::vector<std::string> lines;
    log->setSink([&](const std::string& line) { lines.push_back(line); });
    EXPECT_EQ(log->errors(), 0u);
    // a core profile refuses a buffer name that glGenBuffers never gave
    (*context)->gl().BindBuffer(GL_ARRAY_BUFFER, 123456u);
    EXPECT_EQ(log->errors(), 1u);
    ASSERT_FALSE(lines.empty());
    std::printf("%s\n", lines.front().c_str());
    EXPECT_NE(lines.front().find("error"), std::string::npos);
}

// Validation reads what the GPU holds: a buffer changed behind the renderer's back is caught at
// the next sync, though nothing was uploaded.
TEST(RenderValidation, SeesABufferChangedBehindTheRenderersBack) {
    Terrain t = testing::makeHills(7, 257, 257, 1.0);
    testing::RenderScene scene(t, 1.0, kBattleWidth, kBattleHeight, testBackend());
    ASSERT_TRUE(scene.ok());
    roam::Camera camera;
    camera.eye = {-30.0, -30.0, 80.0};
    camera.forward = glm::dvec3(128.0, 128.0, 30.0) - camera.eye;
    camera.viewport_width = kBattleWidth;
    camera.viewport_height = kBattleHeight;
    (void)scene.frame(camera);
    EXPECT_TRUE(scene.renderer->validation().clean());
    // every buffer of the context: zeros over its first 256 bytes
    const render::GlApi& gl = scene.context->gl();
    const std::vector<unsigned char> zeros(256, 0);
    int overwritten = 0;
    for (unsigned name = 1; name < 4096; ++name) {
        if (gl.IsBuffer(name) == GL_FALSE)
            continue;
        gl.BindBuffer(GL_COPY_WRITE_BUFFER, name);
        GLint size = 0;
        gl.GetBufferParameteriv(GL_COPY_WRITE_BUFFER, GL_BUFFER_SIZE, &size);
        GLint mapped = GL_FALSE;
        gl.GetBufferParameteriv(GL_COPY_WRITE_BUFFER, GL_BUFFER_MAPPED, &mapped);
        if (size < 256 || mapped == GL_TRUE)
            continue; // the ring, mapped for good
        gl.BufferSubData(GL_COPY_WRITE_BUFFER, 0, 256, zeros.data());
        ++overwritten;
    }
    ASSERT_GT(overwritten, 0);
    render::UploadStats still;
    (void)scene.frame(camera, &still);
    EXPECT_EQ(still.bytes(), 0u);
    const render::ValidationReport& v = scene.renderer->validation();
    EXPECT_GT(v.vertex_mismatches + v.index_mismatches, 0u);
    std::printf("validation after the overwrite: %s\n", v.first_problem.c_str());
}

} // namespace
} // namespace terrain

namespace terrain {
namespace {

// GPU time comes back from timer queries a few frames late, without waiting, one value per
// frame, each within the wall time the frames took.
TEST(GpuTimer, FramesComeBackTimedWithinTheirWallTime) {
    Terrain t = testing::makeHills(7, 257, 257, 1.0);
    testing::RenderScene scene(t, 1.0, kBattleWidth, kBattleHeight, testBackend());
    ASSERT_TRUE(scene.ok());
    render::GpuTimer timer(scene.context->gl());
    roam::Camera camera;
    camera.eye = {-30.0, -30.0, 80.0};
    camera.forward = glm::dvec3(128.0, 128.0, 30.0) - camera.eye;
    camera.viewport_width = kBattleWidth;
    camera.viewport_height = kBattleHeight;
    std::vector<double> times;
    std::array<double, render::GpuTimer::kQueries> done{};
    const auto start = std::chrono::steady_clock::now();
    constexpr int kFrames = 30;
    for (int f = 0; f < kFrames + 8; ++f) {
        if (f < kFrames) {
            camera.eye.x += 1.0;
            scene.tess->update(camera);
            timer.begin();
            scene.renderer->sync(*scene.tess, t);
            scene.renderer->draw(*scene.tess, camera, render::RenderOptions{});
            timer.end();
            scene.context->present();
        } else {
            scene.context->gl().Finish(); // the last ones, to collect them
        }
        const std::size_t n = timer.collect(done);
        times.insert(times.end(), done.begin(), done.begin() + static_cast<std::ptrdiff_t>(n));
    }
    const double wall_ms =
        std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
    EXPECT_EQ(times.size() + timer.skipped() + timer.invalid(), static_cast<std::size_t>(kFrames));
    EXPECT_LE(timer.invalid(), 2u);
    EXPECT_GE(times.size(), static_cast<std::size_t>(kFrames - 4));
    for (const double ms : times) {
        EXPECT_GT(ms, 0.0);
        EXPECT_LT(ms, wall_ms);
    }
    timer.release();
}

} // namespace
} // namespace terrain

namespace terrain {
namespace {

// A crater's uploads are what it changed in the buffers: over a battle watched from a still
// camera, the bytes sent (tiles already loaded) stay within 4 times the bytes that differ in the
// buffers afterwards (vertices, and index pages: the renderer's unit), read back and compared.
TEST(RenderBattleUploads, ACratersUploadsAreWithinFourTimesWhatItChanged) {
    Terrain t = testing::makeHills(21, 385, 385, 1.0);
    testing::RenderScene scene(t, 1.0, kBattleWidth, kBattleHeight, testBackend());
    ASSERT_TRUE(scene.ok());
    const lodlab::BattleZone zone = lodlab::battleZone(t);
    roam::Camera camera;
    const glm::dvec3 centre(zone.x, zone.y, surfaceHeight(t, zone.x, zone.y));
    camera.eye = centre + glm::dvec3(-30.0, -22.0, 18.0);
    camera.forward = centre - camera.eye;
    camera.viewport_width = kBattleWidth;
    camera.viewport_height = kBattleHeight;
    BattleGenerator shots = lodlab::battleGenerator(t);
    // settle: the mesh and the buffers reach the view
    for (int f = 0; f < 20; ++f)
        (void)scene.frame(camera);
    const render::ValidationReport before = scene.renderer->validation();
    std::uint64_t sent = 0;
    int craters = 0;
    for (int f = 0; f < 200; ++f) {
        if (f % 4 == 0) {
            const BattleShot shot = shots.next(t);
            if (shot.crater)
                if (auto op = quantizeOp(*shot.crater, t.spec()))
                    if (auto effect = t.apply(*op)) {
                        scene.tess->terrainChanged(
                            std::span<const CellRect>(&effect->cells, 1), false);
                        ++craters;
                    }
        }
        (void)scene.frame(camera);
        sent += scene.uploaded.bytes() - scene.uploaded.load_bytes;
    }
    const render::ValidationReport& after = scene.renderer->validation();
    const std::uint64_t changed = (after.changed_vertex_bytes - before.changed_vertex_bytes) +
                                  (after.changed_index_bytes - before.changed_index_bytes);
    std::printf(
        "%d craters from a still camera: %.1f KB sent, %.1f KB changed in the buffers "
        "(%.2f x)\n",
        craters, sent / 1024.0, changed / 1024.0, static_cast<double>(sent) / changed);
    EXPECT_GE(craters, 40);
    EXPECT_GT(changed, 0u);
    EXPECT_LE(sent, 4 * changed);
    scene.expectClean();
}

} // namespace
} // namespace terrain
