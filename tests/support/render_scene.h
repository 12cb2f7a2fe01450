#pragma once

// One offscreen context (a debug context: KHR_debug output counted), a renderer and a
// tessellator over a terrain, for the render tests.

#include <terrain/render/offscreen.h>
#include <terrain/render/terrain_renderer.h>
#include <terrain/roam/tessellator.h>

#include <gtest/gtest.h>

#include <memory>

namespace terrain::testing {

struct RenderScene {
    std::unique_ptr<render::GlContext> context;
    std::unique_ptr<render::TerrainRenderer> renderer;
    std::unique_ptr<roam::Tessellator> tess;
    const Terrain* terrain = nullptr;
    render::UploadStats uploaded; ///< the last frame's sync
    render::UploadStats morphed;  ///< the last frame's geomorph uploads

    RenderScene(
        const Terrain& t,
        double tau,
        int width,
        int height,
        render::OffscreenBackend backend = render::OffscreenBackend::kOsmesa,
        render::RendererOptions options = validating())
        : terrain(&t) {
        render::ContextOptions co;
        co.debug = true;
        auto c = render::createOffscreenContext(backend, width, height, co);
        if (!c.ok()) {
            ADD_FAILURE() << c.error().message;
            return;
        }
        context = std::move(*c);
        auto r = render::TerrainRenderer::create(*context, options);
        if (!r.ok()) {
            ADD_FAILURE() << r.error().message;
            return;
        }
        renderer = std::move(*r);
        roam::TessellatorOptions o;
        o.tau_pixels = tau;
        o.work_budget = 1 << 30;
        tess = std::make_unique<roam::Tessellator>(t, o);
    }
    bool ok() const { return renderer != nullptr; }

    static render::RendererOptions validating() {
        render::RendererOptions o;
        o.validate = true;
        return o;
    }

    io::RgbImage frame(
        const roam::Camera& camera,
        render::UploadStats* uploads = nullptr,
        render::DrawMode mode = render::DrawMode::kShaded) {
        tess->update(camera);
        uploaded = renderer->sync(*tess, *terrain);
        if (uploads != nullptr)
            *uploads = uploaded;
        morphed = renderer->morph(*tess, camera);
        render::RenderOptions options;
        options.mode = mode;
        renderer->draw(*tess, camera, options);
        return context->readPixels();
    }

    /// Errors the driver reported through KHR_debug (0 where it has none to report).
    std::uint64_t glErrors() const {
        return context && context->debugLog() ? context->debugLog()->errors() : 0;
    }

    /// Every validation and debug finding so far is clean (call at a test's end).
    void expectClean() const {
        if (!ok())
            return;
        const render::ValidationReport& v = renderer->validation();
        EXPECT_TRUE(v.clean()) << v.vertex_mismatches << " vertices, " << v.index_mismatches
                               << " indices differ, " << v.short_buffers
                               << " buffers short; first: " << v.first_problem;
        ASSERT_NE(context->debugLog(), nullptr) << "the context has no KHR_debug";
        EXPECT_EQ(context->debugLog()->errors(), 0u)
            << (context->debugLog()->kept().empty() ? "" : context->debugLog()->kept().front());
    }
};

} // namespace terrain::testing
