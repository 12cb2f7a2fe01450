// The renderer on OSMesa (llvmpipe): a crater shows where it was made and nowhere else, the
// ROAM mesh at tau = 1 px looks like the full-resolution mesh, and buffers are uploaded only
// where the tessellation changed.

#include "support/image_checks.h"
#include "support/render_scene.h"
#include "support/terrain_builders.h"

#include <terrain/render/offscreen.h>
#include <terrain/render/terrain_renderer.h>
#include <terrain/roam/tessellator.h>
#include <terrain/surface_query.h>

#include <glm/geometric.hpp>
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>

namespace terrain {
namespace {

using testing::countDiffering;
using testing::distinctColours;

constexpr int kWidth = 480;
constexpr int kHeight = 320;

std::filesystem::path outputDir() {
    const auto dir = std::filesystem::path(TERRAIN_TEST_OUTPUT_DIR) / "render";
    std::filesystem::create_directories(dir);
    return dir;
}

roam::Camera lookAt(glm::dvec3 eye, glm::dvec3 target) {
    roam::Camera c;
    c.eye = eye;
    c.forward = target - eye;
    c.viewport_width = kWidth;
    c.viewport_height = kHeight;
    c.near_plane = 0.5;
    return c;
}

/// One offscreen context (debug), validating renderer and tessellator over `terrain`.
struct Scene : testing::RenderScene {
    Scene(
        const Terrain& t,
        double tau,
        render::OffscreenBackend backend = render::OffscreenBackend::kOsmesa)
        : RenderScene(t, tau, kWidth, kHeight, backend) {}
    ~Scene() { expectClean(); }
};

Terrain craterWorld() {
    Terrain t = testing::makeHills(11, 257, 257, 1.0);
    return t;
}

OpEffect blast(Terrain& t, double x, double y, double radius, double depth) {
    OpRequest r;
    r.kind = OpKind::kCrater;
    r.x = x;
    r.y = y;
    r.radius = radius;
    r.height = depth;
    r.strength = 0.3;
    auto op = quantizeOp(r, t.spec());
    EXPECT_TRUE(op.ok());
    auto effect = t.apply(*op);
    EXPECT_TRUE(effect.ok());
    return *effect;
}

class OffscreenRender : public ::testing::TestWithParam<render::OffscreenBackend> {};

TEST_P(OffscreenRender, ACraterChangesThePixelsWhereItIsAndNoOthers) {
    Terrain t = craterWorld();
    Scene scene(t, 1.0, GetParam());
    ASSERT_TRUE(scene.ok());
    const glm::dvec3 centre(128.0, 128.0, surfaceHeight(t, 128.0, 128.0));
    const roam::Camera camera = lookAt(centre + glm::dvec3(-45.0, -32.0, 40.0), centre);

    const io::RgbImage before = scene.frame(camera);
    const OpEffect effect = blast(t, centre.x, centre.y, 12.0, 5.0);
    scene.tess->terrainChanged(std::span<const CellRect>(&effect.cells, 1), false);
    const io::RgbImage after = scene.frame(camera);
    const std::string backend = render::toString(GetParam());
    ASSERT_TRUE(io::writeRgbPng(outputDir() / (backend + "_crater_before.png"), before).ok());
    ASSERT_TRUE(io::writeRgbPng(outputDir() / (backend + "_crater_after.png"), after).ok());

    // a real picture: terrain colours, not one flat fill
    EXPECT_GT(distinctColours(before), 2000);

    // where the crater projects: inside its radius, outside its reach (ejecta: 2 radii)
    const roam::ViewMetric view(camera);
    // the screen ellipse of a horizontal circle around the crater (its projected extent)
    const auto projectedWithin = [&](double metres) {
        const roam::ScreenPoint c = view.project(centre);
        double rx = 0.0;
        double ry = 0.0;
        for (int k = 0; k < 64; ++k) {
            const double a = k * 2.0 * 3.14159265358979 / 64.0;
            const roam::ScreenPoint s =
                view.project(centre + glm::dvec3(metres * std::cos(a), metres * std::sin(a), 0.0));
            rx = std::max(rx, std::abs(s.x - c.x));
            ry = std::max(ry, std::abs(s.y - c.y));
        }
        return [c, rx, ry](int px, int py) {
            const double dx = (px + 0.5 - c.x) / rx;
            const double dy = (py + 0.5 - c.y) / ry;
            return dx * dx + dy * dy <= 1.0;
        };
    };
    const auto inner = projectedWithin(8.0);
    const auto reach = projectedWithin(2.0 * 12.0 + 4.0);
    const testing::PixelCount inside = countDiffering(before, after, 16, inner);
    const testing::PixelCount outside =
        countDiffering(before, after, 4, [&](int x, int y) { return !reach(x, y); });
    std::printf(
        "crater: %lld of %lld pixels inside changed, %lld of %lld outside\n",
        static_cast<long long>(inside.differing), static_cast<long long>(inside.counted),
        static_cast<long long>(outside.differing), static_cast<long long>(outside.counted));
    EXPECT_GT(inside.counted, 500);
    EXPECT_GT(inside.fraction(), 0.6);
    EXPECT_GT(outside.counted, kWidth * kHeight / 2);
    EXPECT_LT(outside.fraction(), 0.002);
}

INSTANTIATE_TEST_SUITE_P(
    Backends,
    OffscreenRender,
    ::testing::Values(render::OffscreenBackend::kOsmesa, render::OffscreenBackend::kEgl),
    [](const auto& p) { return std::string(render::toString(p.param)); });

// Both offscreen backends draw one scene alike (on this machine both are llvmpipe).
TEST(OffscreenBackends, OsmesaAndEglDrawTheSamePicture) {
    Terrain t = craterWorld();
    blast(t, 100.0, 140.0, 9.0, 3.0);
    Scene osmesa(t, 1.0, render::OffscreenBackend::kOsmesa);
    Scene egl(t, 1.0, render::OffscreenBackend::kEgl);
    ASSERT_TRUE(osmesa.ok() && egl.ok());
    const roam::Camera camera = lookAt({40.0, 60.0, 70.0}, {128.0, 128.0, 30.0});
    const io::RgbImage a = osmesa.frame(camera);
    // each context draws its own pictures, whichever was made current last
    const roam::Camera other = lookAt({200.0, 30.0, 60.0}, {100.0, 150.0, 20.0});
    const io::RgbImage elsewhere = egl.frame(other);
    const io::RgbImage again = osmesa.context->readPixels();
    EXPECT_EQ(countDiffering(again, a, 0).differing, 0);
    EXPECT_GT(countDiffering(elsewhere, a, 16).fraction(), 0.2);
    const io::RgbImage b = egl.frame(camera);
    std::printf(
        "osmesa (%s) vs egl (%s)\n", osmesa.context->describe().c_str(),
        egl.context->describe().c_str());
    EXPECT_GT(distinctColours(a), 2000);
    EXPECT_LT(countDiffering(a, b, 2).fraction(), 0.001);
}

} // namespace
} // namespace terrain

namespace terrain {
namespace {

// The image error of view-dependent LOD: the ROAM mesh at tau = 1 px against every triangle of
// the model (the tessellator refined to its finest level everywhere), same shading, same
// normals. Differences are confined to silhouettes and shading of merged triangles.
TEST(OsmesaRender, RoamAtOnePixelLooksLikeTheFullResolutionMesh) {
    Terrain t = testing::makeHills(4, 257, 257, 1.0);
    for (int k = 0; k < 12; ++k)
        blast(t, 40.0 + 15.0 * k, 60.0 + 11.0 * k, 3.0 + k, 1.0 + 0.4 * k);
    Scene roam1(t, 1.0);
    Scene full(t, 1e-4);
    ASSERT_TRUE(roam1.ok() && full.ok());
    const std::vector<roam::Camera> views = {
        lookAt({-20.0, -20.0, 70.0}, {128.0, 128.0, 30.0}),
        lookAt({100.0, 40.0, 55.0}, {150.0, 150.0, 35.0}),
        lookAt({230.0, 30.0, 90.0}, {60.0, 200.0, 20.0}),
    };
    testing::PixelCount total;
    std::int64_t roam_triangles = 0;
    std::int64_t full_triangles = 0;
    for (std::size_t v = 0; v < views.size(); ++v) {
        const io::RgbImage a = roam1.frame(views[v]);
        const io::RgbImage b = full.frame(views[v]);
        roam_triangles += roam1.tess->triangleCount();
        full_triangles += full.tess->triangleCount();
        const testing::PixelCount n = countDiffering(a, b, 16);
        std::printf(
            "view %zu: %.3f %% of pixels differ by more than 16/255 (ROAM %lld triangles, "
            "full %lld)\n",
            v, 100.0 * n.fraction(), static_cast<long long>(roam1.tess->triangleCount()),
            static_cast<long long>(full.tess->triangleCount()));
        if (v == 0) {
            ASSERT_TRUE(io::writeRgbPng(outputDir() / "tau1.png", a).ok());
            ASSERT_TRUE(io::writeRgbPng(outputDir() / "full_resolution.png", b).ok());
        }
        total.counted += n.counted;
        total.differing += n.differing;
    }
    ::testing::Test::RecordProperty("differing_percent", std::to_string(100.0 * total.fraction()));
    std::printf(
        "tau 1 px vs full resolution: %.3f %% of pixels differ; %.1f %% of the triangles\n",
        100.0 * total.fraction(), 100.0 * double(roam_triangles) / double(full_triangles));
    EXPECT_LT(total.fraction(), 0.03);
    EXPECT_LT(roam_triangles * 4, full_triangles); // and it needed far fewer triangles
}

// Geomorphing draws what slides, within tau of the full mesh, sends only vertices that moved,
// and turned off draws the plain mesh again.
TEST(OsmesaRender, GeomorphDrawsTheSlidingHeightsWithinTauAndSendsOnlyWhatMoved) {
    Terrain t = testing::makeHills(4, 257, 257, 1.0);
    for (int k = 0; k < 12; ++k)
        blast(t, 40.0 + 15.0 * k, 60.0 + 11.0 * k, 3.0 + k, 1.0 + 0.4 * k);
    // refined to half a pixel, drawn within one
    Scene morph(t, 0.5);
    Scene plain(t, 0.5);
    Scene full(t, 1e-4);
    ASSERT_TRUE(morph.ok() && plain.ok() && full.ok());
    morph.renderer->setGeomorph(0.5);
    const roam::Camera view = lookAt({-20.0, -20.0, 70.0}, {128.0, 128.0, 30.0});
    const io::RgbImage a = morph.frame(view);
    EXPECT_GT(morph.morphed.vertex_bytes, 0u) << "vertices slide at this view";
    const io::RgbImage b = plain.frame(view);
    EXPECT_EQ(plain.morphed.vertex_bytes, 0u) << "geomorphing is off";
    const io::RgbImage c = full.frame(view);
    EXPECT_GT(countDiffering(a, b, 0).differing, 0) << "the slide is drawn";
    const testing::PixelCount n = countDiffering(a, c, 16);
    std::printf(
        "geomorph (0.5 px refined, 1 px drawn) vs full resolution: %.3f %% of pixels differ\n",
        100.0 * n.fraction());
    EXPECT_LT(n.fraction(), 0.03);
    // the same view again: nothing slides, nothing is sent
    (void)morph.frame(view);
    EXPECT_EQ(morph.morphed.vertex_bytes, 0u);
    // a step closer: only vertices that moved, far fewer than the tiles hold
    roam::Camera closer = view;
    closer.eye += glm::normalize(view.forward) * 2.0;
    (void)morph.frame(closer);
    EXPECT_GT(morph.morphed.vertex_bytes, 0u);
    EXPECT_LT(morph.morphed.vertex_bytes, morph.renderer->shadowBytes() / 2);
    // turned off: the true heights come back, the same picture as the plain renderer's
    morph.renderer->setGeomorph(0.0);
    (void)plain.frame(closer);
    const io::RgbImage off = morph.frame(closer);
    EXPECT_GT(morph.morphed.vertex_bytes, 0u) << "the true heights are sent back";
    EXPECT_EQ(countDiffering(off, plain.frame(closer), 0).differing, 0);
}

// Buffers follow the tessellation: a still camera uploads nothing, a crater uploads the tiles
// it changed, and the renderer sends the bytes the tiles' dirty pages hold (and the single clean
// pages between them, at most as many again).
TEST(OsmesaRender, UploadsOnlyWhatChanged) {
    Terrain t = testing::makeHills(7, 257, 257, 1.0);
    Scene scene(t, 1.0);
    ASSERT_TRUE(scene.ok());
    const roam::Camera camera = lookAt({-30.0, -30.0, 80.0}, {128.0, 128.0, 30.0});
    render::UploadStats first;
    scene.frame(camera, &first);
    // the renderer sizes each index buffer to the list it first sees (at least 64 slots)
    std::vector<std::uint32_t> capacity_slots;
    for (std::int32_t tile = 0; tile < scene.tess->tileCount(); ++tile)
        capacity_slots.push_back(std::max(scene.tess->tileMesh(tile).slotCount(), 64u));
    EXPECT_EQ(first.vertex_tiles, static_cast<std::uint32_t>(scene.tess->tileCount()));
    EXPECT_EQ(
        first.vertex_bytes,
        std::uint64_t{16} * roam::kTileBaseVertices * sizeof(render::GpuVertex));
    EXPECT_GT(first.index_bytes, 0u);

    render::UploadStats still;
    scene.frame(camera, &still);
    EXPECT_EQ(still.bytes(), 0u);
    EXPECT_EQ(still.index_uploads, 0u);

    // a crater inside tile 5 (cells 64..127 x 64..127): its vertex array grows detail blocks
    const OpEffect effect = blast(t, 96.0, 96.0, 6.0, 2.0);
    scene.tess->terrainChanged(std::span<const CellRect>(&effect.cells, 1), false);
    scene.tess->update(camera);
    // a changed tile sends its dirty pages; one that outgrew its buffer moves the rest of its
    // list into a bigger one on the GPU, uploading nothing more
    std::uint64_t expected_index_bytes = 0;
    std::uint32_t expected_grown = 0;
    for (std::int32_t tile = 0; tile < scene.tess->tileCount(); ++tile) {
        const roam::TileMesh& mesh = scene.tess->tileMesh(tile);
        if (!mesh.dirty())
            continue;
        expected_index_bytes += mesh.dirtyUploadBytes();
        expected_grown += mesh.slotCount() > capacity_slots[static_cast<std::size_t>(tile)] ? 1 : 0;
    }
    const render::UploadStats after = scene.renderer->sync(*scene.tess, t);
    // the new blocks and the base grid around the crater, not the tile's whole array
    const std::uint64_t tile_bytes =
        std::uint64_t(scene.tess->tileVertexCount(5)) * sizeof(render::GpuVertex);
    EXPECT_EQ(after.vertex_tiles, 1u);
    EXPECT_GT(after.vertex_bytes, 0u);
    EXPECT_LT(after.vertex_bytes, tile_bytes);
    std::printf(
        "crater: %llu vertex bytes uploaded of the tile's %llu\n",
        static_cast<unsigned long long>(after.vertex_bytes),
        static_cast<unsigned long long>(tile_bytes));
    // the dirty pages, and the clean pages single gaps between them bridge (fewer copies)
    EXPECT_GE(after.index_bytes, expected_index_bytes);
    EXPECT_LE(after.index_bytes, 2 * expected_index_bytes);
    EXPECT_GE(after.grown_buffers, expected_grown);
    EXPECT_GT(after.index_bytes, 0u);
    EXPECT_LE(after.index_tiles, 4u);
    EXPECT_EQ(scene.renderer->totals().bytes(), first.bytes() + after.bytes());

    // a second crater in the same tile: its new blocks and the grid around it are sent, the
    // first crater's blocks are not
    const OpEffect second = blast(t, 72.0, 118.0, 5.0, 2.0);
    scene.tess->terrainChanged(std::span<const CellRect>(&second.cells, 1), false);
    render::UploadStats again;
    scene.frame(camera, &again);
    const std::uint64_t tile_bytes_now =
        std::uint64_t(scene.tess->tileVertexCount(5)) * sizeof(render::GpuVertex);
    std::printf(
        "second crater: %llu vertex bytes uploaded of the tile's %llu\n",
        static_cast<unsigned long long>(again.vertex_bytes),
        static_cast<unsigned long long>(tile_bytes_now));
    EXPECT_LE(again.vertex_tiles, 4u); // its reach and normals touch the tiles around
    EXPECT_LT(again.vertex_bytes * 10, tile_bytes_now * 7);

    // partial uploads leave the buffers as a full upload would: the same picture, bit for bit
    render::RenderOptions options;
    scene.renderer->draw(*scene.tess, camera, options);
    const io::RgbImage incremental = scene.context->readPixels();
    auto fresh = render::TerrainRenderer::create(*scene.context);
    ASSERT_TRUE(fresh.ok());
    const render::UploadStats all = (*fresh)->sync(*scene.tess, t);
    EXPECT_EQ(all.vertex_tiles, 16u);
    (*fresh)->draw(*scene.tess, camera, options);
    const io::RgbImage rebuilt = scene.context->readPixels();
    EXPECT_EQ(countDiffering(incremental, rebuilt, 0).differing, 0);
}

TEST(OsmesaRender, TilesOutOfViewGiveTheirBuffersBackAndReloadTheSamePixels) {
    Terrain t = testing::makeHills(7, 257, 257, 1.0);
    Scene scene(t, 1.0);
    ASSERT_TRUE(scene.ok());
    scene.renderer->setEvictAfterFrames(3);
    // looking down on one corner of the map: the tiles far from it stay out of view
    const roam::Camera towards = lookAt({40.0, 40.0, 70.0}, {60.0, 60.0, 0.0});
    const roam::Camera away = lookAt({40.0, 40.0, 70.0}, {-100.0, -100.0, 70.0});
    const io::RgbImage first = scene.frame(towards);
    const std::uint32_t resident = scene.renderer->residentTiles();
    const std::uint64_t gpu = scene.renderer->gpuBytes();
    EXPECT_GT(resident, 0u);
    EXPECT_LT(resident, static_cast<std::uint32_t>(scene.tess->tileCount()))
        << "a tile never in view is never loaded";
    for (int f = 0; f < 6; ++f)
        scene.frame(away);
    EXPECT_GT(scene.renderer->totals().evicted_tiles, 0u);
    EXPECT_LT(scene.renderer->gpuBytes(), gpu);
    for (int f = 0; f < 3; ++f) // back: the tiles load again (and the mesh settles)
        scene.frame(towards);
    EXPECT_EQ(scene.renderer->residentTiles(), resident);
    const io::RgbImage back = scene.frame(towards);
    EXPECT_EQ(countDiffering(first, back, 0).differing, 0);
    // and what a renderer that never evicted anything draws for the same mesh
    auto fresh = render::TerrainRenderer::create(*scene.context);
    ASSERT_TRUE(fresh.ok());
    (*fresh)->sync(*scene.tess, t);
    (*fresh)->draw(*scene.tess, towards, render::RenderOptions{});
    EXPECT_EQ(countDiffering(back, scene.context->readPixels(), 0).differing, 0);
    EXPECT_EQ(scene.renderer->shadowBytes(), (*fresh)->shadowBytes());
}

// A rebuild rewrites every tile's list into the buffer it has: GPU memory stays bounded however
// often the tessellation is rebuilt (a tau slider dragged, a window resized).
TEST(OsmesaRender, RebuildsReuseTheIndexBuffers) {
    Terrain t = testing::makeHills(7, 257, 257, 1.0);
    Scene scene(t, 1.0);
    ASSERT_TRUE(scene.ok());
    const roam::Camera camera = lookAt({-30.0, -30.0, 80.0}, {128.0, 128.0, 30.0});
    std::uint64_t settled = 0;
    for (int k = 0; k < 40; ++k) {
        scene.tess->setTau(k % 2 == 0 ? 1.0 : 3.0);
        render::UploadStats up;
        scene.frame(camera, &up);
        EXPECT_GT(up.index_tiles, 0u) << k; // every frame was a rebuild
        if (k == 3)
            settled = scene.renderer->gpuBytes();
    }
    EXPECT_EQ(scene.renderer->gpuBytes(), settled);
}

} // namespace
} // namespace terrain
