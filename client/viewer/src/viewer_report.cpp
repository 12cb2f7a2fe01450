#include <terrain/viewer/viewer_report.h>

#include <nlohmann/json.hpp>

#include <cstdio>
#include <fstream>

namespace terrain::viewer {

std::string hashHex(std::uint64_t hash) {
    char text[17];
    std::snprintf(text, sizeof text, "%016llx", static_cast<unsigned long long>(hash));
    return text;
}

Status writeViewerReport(const std::filesystem::path& path, const ViewerReport& r) {
    nlohmann::json j;
    j["server"] = r.server;
    j["in_process"] = r.in_process;
    j["renderer"] = r.renderer;
    j["width"] = r.width;
    j["height"] = r.height;
    j["tau_pixels"] = r.tau_pixels;
    j["frames"] = r.frames;
    j["seq"] = r.seq;
    j["world_hash"] = hashHex(r.world_hash);
    j["verified_seq"] = r.verified_seq;
    j["hash_mismatches"] = r.hash_mismatches;
    j["repairs"] = r.repairs;
    j["synced"] = r.synced;
    j["diverged"] = r.diverged;
    if (r.server_seq)
        j["server_seq"] = *r.server_seq;
    if (r.server_world_hash)
        j["server_world_hash"] = hashHex(*r.server_world_hash);
    j["triangles"] = r.triangles;
    j["visible_triangles"] = r.visible_triangles;
    j["median_frame_ms"] = r.median_frame_ms;
    j["median_tessellation_ms"] = r.median_tessellation_ms;
    j["median_draw_ms"] = r.median_draw_ms;
    j["median_gpu_ms"] = r.median_gpu_ms;
    j["upload_path"] = r.upload_path;
    j["gl_errors"] = r.gl_errors;
    j["gl_messages"] = r.gl_messages;
    j["buffer_mismatches"] = r.buffer_mismatches;
    j["bytes_uploaded"] = r.bytes_uploaded;
    j["rtt_ms"] = r.rtt_ms;
    j["craters_requested"] = r.craters_requested;
    j["craters_accepted"] = r.craters_accepted;
    j["craters_refused"] = r.craters_refused;
    j["craters_missed"] = r.craters_missed;
    j["screenshot"] = r.screenshot;
    std::ofstream out(path);
    out << j.dump(2) << "\n";
    out.close();
    if (!out)
        return makeError(ErrorCode::kIo, "cannot write report " + path.string());
    return Ok{};
}

} // namespace terrain::viewer
