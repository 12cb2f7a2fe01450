#pragma once

// One client's terrain frame, as the bot and the viewer run it: the replica's changes fed to the
// tessellator, the tessellation for the frame's camera, the triangle cap steered by measured
// frame times, and the crater a click at a pixel asks for. No GL, clocks or sockets: the caller
// draws (a renderer reads tessellator()), times its frames and sends the request.

#include <terrain/client/frame_budget.h>
#include <terrain/client/replica.h>
#include <terrain/client/tessellation_feed.h>
#include <terrain/deform_op.h>
#include <terrain/roam/tessellator.h>

#include <optional>

namespace terrain::client {

struct TerrainViewOptions {
    roam::TessellatorOptions tessellation;
    /// target_ms 0: no steering (the cap stays tessellation.max_triangles).
    FrameBudgetOptions budget;
};

class TerrainView {
  public:
    /// Starts from the replica's state now (what it changed before is dropped); the replica
    /// must outlive the view.
    TerrainView(Replica& replica, const TerrainViewOptions& options);

    /// Feeds what the replica changed since the last call (ops, repairs, a snapshot of any
    /// world) to the tessellator; whether anything changed.
    bool absorb();
    /// Tessellates for `camera` (call absorb() first, or the mesh lags the replica).
    const roam::FrameStats& update(const roam::Camera& camera);
    /// The frame took `frame_ms` (the larger of the CPU's and the GPU's time, where the GPU's
    /// is known): the triangle cap follows the budget.
    void steer(double frame_ms);

    roam::Tessellator& tessellator() { return tess_; }
    const roam::Tessellator& tessellator() const { return tess_; }
    const FrameBudget& budget() const { return budget_; }
    /// What the last update() did.
    const roam::FrameStats& lastStats() const { return last_; }

  private:
    Replica* replica_;
    roam::Tessellator tess_;
    FrameBudget budget_;
    roam::FrameStats last_;
};

/// A crater as the player asks for it (metres; rim as a fraction of the depth).
struct CraterShape {
    double radius = 3.0;
    double depth = 1.5;
    double rim = 0.3;
};

/// The crater request for pixel (px, py) of `camera`'s view: where the ray through the pixel
/// meets the true surface; nothing if it misses the terrain.
std::optional<OpRequest> craterAtPixel(
    const Terrain& terrain,
    const roam::Camera& camera,
    double px,
    double py,
    const CraterShape& shape);

} // namespace terrain::client
