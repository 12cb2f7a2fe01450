#include <terrain/bot/bot_report.h>

#include <nlohmann/json.hpp>

#include <algorithm>
#include <cinttypes>
#include <fstream>
#include <sstream>

namespace terrain::bot {

namespace {
using nlohmann::json;

json spreadJson(const Spread& s) {
    return json{{"median", s.median}, {"p95", s.p95}, {"max", s.max}};
}

Spread spreadFrom(const json& j) {
    return Spread{
        j.at("median").get<double>(), j.at("p95").get<double>(), j.at("max").get<double>()};
}

std::string hex(std::uint64_t v) {
    char text[24];
    std::snprintf(text, sizeof text, "%016" PRIx64, v);
    return text;
}
} // namespace

Spread Spread::of(std::vector<double> values) {
    Spread s;
    if (values.empty())
        return s;
    std::sort(values.begin(), values.end());
    const auto rank = [&](double q) {
        const auto k = static_cast<std::size_t>(q * static_cast<double>(values.size() - 1) + 0.5);
        return values[std::min(k, values.size() - 1)];
    };
    s.median = rank(0.5);
    s.p95 = rank(0.95);
    s.max = values.back();
    return s;
}

std::string toJson(const BotReport& r) {
    const json j = {
        {"name", r.name},
        {"frames", r.frames},
        {"seconds", r.seconds},
        {"join_seconds", r.join_seconds},
        {"final_seq", r.final_seq},
        {"world_hash", hex(r.world_hash)},
        {"synced", r.synced},
        {"ops_applied", r.ops_applied},
        {"hash_mismatches", r.hash_mismatches},
        {"repairs", r.repairs},
        {"snapshots", r.snapshots},
        {"genesis_deltas", r.genesis_deltas},
        {"snapshot_bytes", r.snapshot_bytes},
        {"craters",
         {{"requested", r.craters_requested},
          {"accepted", r.craters_accepted},
          {"refused", r.craters_refused},
          {"missed", r.craters_missed}}},
        {"tessellate_ms", spreadJson(r.tessellate_ms)},
        {"async_tessellation", r.async_tessellation},
        {"lag_frames", spreadJson(r.lag_frames)},
        {"crater_frames_to_drawn", spreadJson(r.crater_frames_to_drawn)},
        {"crater_frames_to_converged", spreadJson(r.crater_frames_to_converged)},
        {"crater_error_bound_until_converged_px",
         spreadJson(r.crater_error_bound_until_converged_px)},
        {"render_ms", spreadJson(r.render_ms)},
        {"sync_ms", spreadJson(r.sync_ms)},
        {"draw_ms", spreadJson(r.draw_ms)},
        {"present_ms", spreadJson(r.present_ms)},
        {"gpu_ms", spreadJson(r.gpu_ms)},
        {"gpu_frames", r.gpu_frames},
        {"frame_ms", spreadJson(r.frame_ms)},
        {"triangles", spreadJson(r.triangles)},
        {"visible_triangles", spreadJson(r.visible_triangles)},
        {"triangle_cap", spreadJson(r.triangle_cap)},
        {"error_bound_pixels", spreadJson(r.error_bound_pixels)},
        {"upload",
         {{"bytes", r.upload_bytes},
          {"vertex_bytes", r.vertex_bytes},
          {"index_bytes", r.index_bytes},
          {"per_frame", spreadJson(r.upload_bytes_per_frame)},
          {"path", r.upload_path},
          {"gpu_copies", r.gpu_copies},
          {"copies_per_frame", spreadJson(r.copies_per_frame)},
          {"ring_waits", r.ring_waits}}},
        {"after_holes", r.after_holes},
        {"gl_errors", r.gl_errors},
        {"gl_messages", r.gl_messages},
        {"buffer_mismatches", r.buffer_mismatches},
        {"network",
         {{"bytes_in", r.bytes_in}, {"op_bytes_in", r.op_bytes_in}, {"rtt_ms", r.rtt_ms}}},
        {"renderer", r.renderer},
        {"pngs", r.pngs},
        {"error", r.error},
    };
    return j.dump(2) + "\n";
}

Status writeReport(const std::filesystem::path& path, const BotReport& report) {
    std::ofstream out(path, std::ios::binary | std::ios::trunc);
    out << toJson(report);
    out.close();
    if (!out)
        return makeError(ErrorCode::kIo, "cannot write report " + path.string());
    return Ok{};
}

Result<BotReport> readReport(const std::filesystem::path& path) {
    std::ifstream in(path, std::ios::binary);
    if (!in)
        return makeError(ErrorCode::kIo, "cannot read report " + path.string());
    std::stringstream text;
    text << in.rdbuf();
    try {
        const json j = json::parse(text.str());
        BotReport r;
        r.name = j.at("name").get<std::string>();
        r.frames = j.at("frames").get<int>();
        r.seconds = j.at("seconds").get<double>();
        r.join_seconds = j.at("join_seconds").get<double>();
        r.final_seq = j.at("final_seq").get<std::uint64_t>();
        const std::string hash = j.at("world_hash").get<std::string>();
        if (hash.size() != 16 ||
            hash.find_first_not_of("0123456789abcdefABCDEF") != std::string::npos)
            return makeError(
                ErrorCode::kBadFormat, path.string() + ": world_hash must be 16 hex digits");
        r.world_hash = std::stoull(hash, nullptr, 16);
        r.synced = j.at("synced").get<bool>();
        r.ops_applied = j.at("ops_applied").get<std::uint64_t>();
        r.hash_mismatches = j.at("hash_mismatches").get<std::uint64_t>();
        r.repairs = j.at("repairs").get<std::uint64_t>();
        r.snapshots = j.at("snapshots").get<std::uint64_t>();
        r.genesis_deltas = j.value("genesis_deltas", std::uint64_t{0});
        r.snapshot_bytes = j.value("snapshot_bytes", std::uint64_t{0});
        const json& c = j.at("craters");
        r.craters_requested = c.at("requested").get<int>();
        r.craters_accepted = c.at("accepted").get<int>();
        r.craters_refused = c.at("refused").get<int>();
        r.craters_missed = c.at("missed").get<int>();
        r.tessellate_ms = spreadFrom(j.at("tessellate_ms"));
        // added with the tessellation worker (2026-12-06); older reports lack them
        r.async_tessellation = j.value("async_tessellation", false);
        if (j.contains("lag_frames"))
            r.lag_frames = spreadFrom(j.at("lag_frames"));
        // added with the per-crater measures (2026-12-08); older reports lack them
        if (j.contains("crater_frames_to_drawn")) {
            r.crater_frames_to_drawn = spreadFrom(j.at("crater_frames_to_drawn"));
            r.crater_frames_to_converged = spreadFrom(j.at("crater_frames_to_converged"));
            r.crater_error_bound_until_converged_px =
                spreadFrom(j.at("crater_error_bound_until_converged_px"));
        }
        r.render_ms = spreadFrom(j.at("render_ms"));
        r.frame_ms = spreadFrom(j.at("frame_ms"));
        r.triangles = spreadFrom(j.at("triangles"));
        r.visible_triangles = spreadFrom(j.at("visible_triangles"));
        r.triangle_cap = spreadFrom(j.at("triangle_cap"));
        r.error_bound_pixels = spreadFrom(j.at("error_bound_pixels"));
        const json& u = j.at("upload");
        r.upload_bytes = u.at("bytes").get<std::uint64_t>();
        r.vertex_bytes = u.at("vertex_bytes").get<std::uint64_t>();
        r.index_bytes = u.at("index_bytes").get<std::uint64_t>();
        r.upload_bytes_per_frame = spreadFrom(u.at("per_frame"));
        // fields added with the GPU work (2026-12-04); older reports lack them
        r.upload_path = u.value("path", std::string());
        r.gpu_copies = u.value("gpu_copies", std::uint64_t{0});
        if (u.contains("copies_per_frame"))
            r.copies_per_frame = spreadFrom(u.at("copies_per_frame"));
        r.ring_waits = u.value("ring_waits", std::uint64_t{0});
        if (j.contains("sync_ms")) {
            r.sync_ms = spreadFrom(j.at("sync_ms"));
            r.draw_ms = spreadFrom(j.at("draw_ms"));
            r.present_ms = spreadFrom(j.at("present_ms"));
            r.gpu_ms = spreadFrom(j.at("gpu_ms"));
            r.gpu_frames = j.at("gpu_frames").get<int>();
        }
        r.after_holes = j.value("after_holes", std::int64_t{-1});
        r.gl_errors = j.value("gl_errors", std::int64_t{-1});
        r.gl_messages = j.value("gl_messages", std::int64_t{-1});
        r.buffer_mismatches = j.value("buffer_mismatches", std::int64_t{-1});
        const json& n = j.at("network");
        r.bytes_in = n.at("bytes_in").get<std::uint64_t>();
        r.op_bytes_in = n.at("op_bytes_in").get<std::uint64_t>();
        r.rtt_ms = n.at("rtt_ms").get<double>();
        r.renderer = j.at("renderer").get<std::string>();
        r.pngs = j.at("pngs").get<std::vector<std::string>>();
        r.error = j.at("error").get<std::string>();
        return r;
    } catch (const std::exception& e) {
        // nlohmann names the missing key or the type it expected
        return makeError(ErrorCode::kBadFormat, path.string() + ": not a bot report: " + e.what());
    }
}

bool printTable(const std::vector<BotReport>& reports, std::FILE* out) {
    std::fprintf(
        out, "%-10s %6s %7s %6s %16s %8s %7s %9s %9s %9s %8s %10s %9s\n", "client", "frames",
        "craters", "seq", "world hash", "verified", "repairs", "tess ms", "render ms", "frame ms",
        "tris", "upload KB", "ops KB in");
    for (const BotReport& r : reports) {
        const std::uint64_t verified = r.ops_applied - std::min(r.ops_applied, r.hash_mismatches);
        char craters[24];
        std::snprintf(craters, sizeof craters, "%d/%d", r.craters_accepted, r.craters_requested);
        std::fprintf(
            out,
            "%-10s %6d %7s %6" PRIu64 " %16s %8" PRIu64 " %7" PRIu64
            " %9.2f %9.2f %9.2f %8.0f %10.0f %9.1f\n",
            r.name.c_str(), r.frames, craters, r.final_seq, hex(r.world_hash).c_str(), verified,
            r.repairs, r.tessellate_ms.median, r.render_ms.median, r.frame_ms.median,
            r.triangles.median, static_cast<double>(r.upload_bytes) / 1024.0,
            static_cast<double>(r.op_bytes_in) / 1024.0);
    }
    bool agree = !reports.empty();
    for (const BotReport& r : reports) {
        if (!r.error.empty())
            std::fprintf(out, "%s: %s\n", r.name.c_str(), r.error.c_str());
        agree = agree && r.synced && r.error.empty() && r.final_seq == reports.front().final_seq &&
                r.world_hash == reports.front().world_hash;
    }
    if (agree)
        std::fprintf(
            out,
            "hash agreement: YES, all %zu at seq %" PRIu64 " with world hash %s "
            "(medians per frame; 'verified' = ops whose hash the replica checked equal)\n",
            reports.size(), reports.front().final_seq, hex(reports.front().world_hash).c_str());
    else
        std::fprintf(
            out, "hash agreement: NO (seq or world hash differ, or a client is not "
                 "synced)\n");
    return agree;
}

} // namespace terrain::bot
