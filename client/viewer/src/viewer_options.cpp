#include <terrain/viewer/viewer_options.h>

#include <CLI/CLI.hpp>

#include <charconv>
#include <cmath>

namespace terrain::viewer {

namespace {
Error rule(const std::string& text) {
    return makeError(ErrorCode::kOutOfRange, text);
}
} // namespace

void addViewerOptions(CLI::App& app, ViewerOptions& o) {
    CLI::Option* connect = app.add_option(
        "--connect", o.connect,
        "join the server at host:port (default: run one in-process on 127.0.0.1)");
    app.add_option("--token", o.token, "access token for --connect (deformer to make craters)")
        ->envname("TERRAIN_TOKEN");
    app.add_option("--size", o.size, "in-process map: vertices per side")->excludes(connect);
    app.add_option("--seed", o.seed, "in-process map: procedural seed")->excludes(connect);
    app.add_option(
        "--join-timeout", o.join_timeout_seconds, "seconds to connect and receive the world");
    app.add_option("--width", o.width, "window width in pixels");
    app.add_option("--height", o.height, "window height in pixels");
    app.add_option("--tau", o.tau_pixels, "screen-space error bound in pixels");
    app.add_option(
        "--geomorph", o.geomorph,
        "refine to this share of --tau and slide vertices instead of popping them (0: off)");
    app.add_flag(
        "!--sync-tessellation", o.async_tessellation,
        "tessellate on the frame thread (default: on a worker thread, except with --geomorph)");
    app.add_option("--max-triangles", o.max_triangles, "tessellation triangle cap");
    app.add_option(
        "--frame-ms", o.frame_ms,
        "frame time to hold by lowering the triangle cap (0: off; tau then wins)");
    app.add_option(
           "--ops-per-frame", o.ops_per_frame,
           "ops applied per frame at least; a burst waits for the next frames (0: each op as it "
           "arrives)")
        ->check(CLI::NonNegativeNumber);
    app.add_flag("--wireframe", o.wireframe, "start drawing lines over the shading");
    app.add_flag(
        "--gl-debug", o.gl_debug,
        "a debug GL context: every KHR_debug message to stderr, errors in the report");
    app.add_option("--upload-path", o.upload_path, "auto | persistent | map-range");
    app.add_flag(
        "--validate-buffers", o.validate_buffers,
        "read the GPU buffers back after every sync and compare them with the mesh (slow)");
    app.add_option("--crater-radius", o.crater_radius, "crater radius in metres");
    app.add_option("--crater-depth", o.crater_depth, "crater depth in metres");
    app.add_option("--frames", o.frames, "exit after this many frames (0: when the window closes)");
    app.add_option(
        "--screenshot", o.screenshot, "write the last frame (terrain, no overlay) to this PNG");
    app.add_option(
        "--auto-crater", o.auto_crater,
        "request a crater at the centre-of-screen ray hit every this many frames");
    app.add_flag("--fly", o.fly, "scripted flight: circle the map centre, facing it");
    app.add_option("--report", o.report, "write a JSON report here at exit");
}

Status finishViewerOptions(ViewerOptions& o) {
    if (!(o.tau_pixels > 0.0) || !std::isfinite(o.tau_pixels))
        return rule("--tau must be > 0 (pixels)");
    if (o.upload_path != "auto" && o.upload_path != "persistent" && o.upload_path != "map-range")
        return rule("--upload-path must be auto, persistent or map-range");
    if (!(o.geomorph >= 0.0 && o.geomorph < 1.0))
        return rule("--geomorph must be within [0, 1) (a share of tau; 0 turns it off)");
    if (o.max_triangles < 1000)
        return rule("--max-triangles must be >= 1000");
    if (!(o.frame_ms >= 0.0) || !std::isfinite(o.frame_ms))
        return rule("--frame-ms must be >= 0 (milliseconds; 0 turns the budget off)");
    if (o.width < 1 || o.width > 16384 || o.height < 1 || o.height > 16384)
        return rule("--width and --height must be within 1..16384");
    if (o.size < 65 || o.size > 8193)
        return rule("--size must be within 65..8193 vertices");
    if (!(o.join_timeout_seconds > 0.0) || !std::isfinite(o.join_timeout_seconds))
        return rule("--join-timeout must be > 0 (seconds)");
    if (!(o.crater_radius > 0.0) || !std::isfinite(o.crater_radius))
        return rule("--crater-radius must be > 0 (metres)");
    if (!(o.crater_depth > 0.0) || !std::isfinite(o.crater_depth))
        return rule("--crater-depth must be > 0 (metres)");
    if (o.crater_depth > o.crater_radius)
        return rule(
            "--crater-depth must be at most --crater-radius (a crater is no deeper than wide)");
    if (o.frames < 0)
        return rule("--frames must be >= 0");
    if (o.auto_crater < 0)
        return rule("--auto-crater must be >= 0");
    if (o.inProcess()) {
        o.host = "127.0.0.1";
        o.port = 0; // the in-process server's ephemeral port, known once it listens
        return Ok{};
    }
    const std::size_t colon = o.connect.rfind(':');
    if (colon == std::string::npos || colon == 0)
        return makeError(ErrorCode::kBadFormat, "--connect must be host:port");
    std::string host = o.connect.substr(0, colon);
    if (host.size() >= 2 && host.front() == '[' && host.back() == ']')
        host = host.substr(1, host.size() - 2); // [::1]:7777
    const std::string port_text = o.connect.substr(colon + 1);
    unsigned port = 0;
    const auto [end, ec] =
        std::from_chars(port_text.data(), port_text.data() + port_text.size(), port);
    if (host.empty() || port_text.empty() || ec != std::errc() ||
        end != port_text.data() + port_text.size() || port < 1 || port > 65535)
        return makeError(
            ErrorCode::kBadFormat, "--connect must be host:port with a port in 1..65535");
    if (o.token.empty())
        return rule("--connect needs --token or TERRAIN_TOKEN (a viewer or deformer token)");
    o.host = host;
    o.port = static_cast<std::uint16_t>(port);
    return Ok{};
}

} // namespace terrain::viewer
