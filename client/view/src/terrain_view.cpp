#include <terrain/client/terrain_view.h>
#include <terrain/surface_query.h>

#include <algorithm>
#include <cmath>

namespace terrain::client {

TerrainView::TerrainView(Replica& replica, const TerrainViewOptions& options)
    : replica_(&replica), tess_(replica.terrain(), options.tessellation), budget_(options.budget) {
    replica.takeDirty(); // the tessellator was just built from the state as it is
}

bool TerrainView::absorb() {
    return feedChanges(surfaceChanges(replica_->takeDirty(), replica_->terrain().spec()), tess_);
}

const roam::FrameStats& TerrainView::update(const roam::Camera& camera) {
    last_ = tess_.update(camera);
    return last_;
}

void TerrainView::steer(double frame_ms) {
    tess_.setMaxTriangles(budget_.observe(frame_ms, last_.triangles));
}

std::optional<OpRequest> craterAtPixel(
    const Terrain& terrain,
    const roam::Camera& camera,
    double px,
    double py,
    const CraterShape& shape) {
    const WorldSpec& spec = terrain.spec();
    const glm::dvec3 ray = roam::ViewMetric(camera).rayThrough(px, py);
    // far enough to cross the whole map from an eye outside it
    const double reach =
        2.0 * std::hypot(spec.extentX(), spec.extentY()) + std::abs(camera.eye.z) + 1000.0;
    const std::optional<RayHit> hit = castRay(terrain, camera.eye, ray, reach);
    if (!hit)
        return std::nullopt;
    OpRequest request;
    request.kind = OpKind::kCrater;
    request.x = hit->point.x;
    request.y = hit->point.y;
    request.radius = shape.radius;
    request.height = shape.depth;
    request.strength = shape.rim;
    return request;
}

} // namespace terrain::client
