#include "viewer_overlay.h"

#include <terrain/viewer/viewer_report.h>

#include <backends/imgui_impl_glfw.h>
#include <backends/imgui_impl_opengl3.h>
#include <imgui.h>

namespace terrain::viewer {

Result<std::unique_ptr<ViewerOverlay>> ViewerOverlay::create(GLFWwindow* window) {
    IMGUI_CHECKVERSION();
    std::unique_ptr<ViewerOverlay> overlay(new ViewerOverlay());
    ImGui::CreateContext();
    ImGuiIO& io = ImGui::GetIO();
    io.IniFilename = nullptr; // no imgui.ini in whatever directory the viewer runs from
    ImGui::StyleColorsDark();
    ImGui::GetStyle().Alpha = 0.9f;
    // installs callbacks that chain to any set before; the viewer polls GLFW itself
    overlay->glfw_ready_ = ImGui_ImplGlfw_InitForOpenGL(window, true);
    if (!overlay->glfw_ready_)
        return makeError(ErrorCode::kUnsupported, "Dear ImGui: the GLFW backend did not start");
    overlay->gl_ready_ = ImGui_ImplOpenGL3_Init("#version 330");
    if (!overlay->gl_ready_)
        return makeError(ErrorCode::kUnsupported, "Dear ImGui: the OpenGL 3 backend did not start");
    return overlay;
}

ViewerOverlay::~ViewerOverlay() {
    if (gl_ready_)
        ImGui_ImplOpenGL3_Shutdown();
    if (glfw_ready_)
        ImGui_ImplGlfw_Shutdown();
    ImGui::DestroyContext();
}

bool ViewerOverlay::wantsMouse() const {
    return ImGui::GetIO().WantCaptureMouse;
}

bool ViewerOverlay::wantsKeyboard() const {
    return ImGui::GetIO().WantCaptureKeyboard;
}

namespace {
std::string megabytes(std::uint64_t bytes) {
    char text[32];
    if (bytes < 10 * 1024)
        std::snprintf(text, sizeof text, "%llu B", static_cast<unsigned long long>(bytes));
    else if (bytes < 10 * 1024 * 1024)
        std::snprintf(text, sizeof text, "%.1f KiB", static_cast<double>(bytes) / 1024.0);
    else
        std::snprintf(text, sizeof text, "%.1f MiB", static_cast<double>(bytes) / 1048576.0);
    return text;
}
} // namespace

void ViewerOverlay::draw(const OverlayView& v, OverlayControls& c) {
    ImGui_ImplOpenGL3_NewFrame();
    ImGui_ImplGlfw_NewFrame();
    ImGui::NewFrame();

    ImGui::SetNextWindowPos(ImVec2(8.0f, 8.0f), ImGuiCond_FirstUseEver);
    ImGui::Begin("terrain-viewer", nullptr, ImGuiWindowFlags_AlwaysAutoResize);
    ImGui::Text("server   %s%s", v.server.c_str(), v.in_process ? " (in-process)" : "");
    ImGui::Text("seq      %llu", static_cast<unsigned long long>(v.seq));
    ImGui::Text("hash     %s", hashHex(v.world_hash).c_str());
    const bool verified = v.status == "verified";
    ImGui::TextColored(
        verified ? ImVec4(0.5f, 1.0f, 0.5f, 1.0f) : ImVec4(1.0f, 0.6f, 0.3f, 1.0f),
        "status   %s (verified to seq %llu)", v.status.c_str(),
        static_cast<unsigned long long>(v.verified_seq));
    ImGui::Text("rtt      %.2f ms", v.rtt_ms);
    ImGui::Separator();
    ImGui::Text(
        "triangles %lld visible / %lld", static_cast<long long>(v.visible_triangles),
        static_cast<long long>(v.triangles));
    ImGui::Text(
        "tessellate %.2f ms   draw %.2f ms   GPU %.2f ms", v.tessellation_ms, v.draw_ms, v.gpu_ms);
    ImGui::Text(
        "frame      %.2f ms (%.0f fps)", v.frame_ms, v.frame_ms > 0.0 ? 1000.0 / v.frame_ms : 0.0);
    ImGui::Text(
        "uploaded   %s this frame, %s total", megabytes(v.upload_bytes).c_str(),
        megabytes(v.upload_bytes_total).c_str());
    ImGui::Separator();
    ImGui::SliderFloat(
        "tau (px)", &c.tau_pixels, 0.5f, 16.0f, "%.2f", ImGuiSliderFlags_Logarithmic);
    static const char* const kModes[kDrawModes] = {"shaded", "shaded + wireframe", "wireframe"};
    ImGui::Combo("draw", &c.draw_mode, kModes, kDrawModes);
    ImGui::SliderFloat("crater radius (m)", &c.crater_radius, 1.0f, 64.0f, "%.1f");
    ImGui::SliderFloat("crater depth (m)", &c.crater_depth, 0.5f, 32.0f, "%.1f");
    ImGui::SliderFloat(
        "speed (m/s)", &c.speed, 1.0f, 1000.0f, "%.0f", ImGuiSliderFlags_Logarithmic);
    ImGui::Text(
        "craters  %lld asked, %lld made, %lld refused", static_cast<long long>(v.craters_requested),
        static_cast<long long>(v.craters_accepted), static_cast<long long>(v.craters_refused));
    ImGui::Text("eye      %.0f, %.0f, %.0f m", v.eye[0], v.eye[1], v.eye[2]);
    if (!v.message.empty())
        ImGui::TextWrapped("%s", v.message.c_str());
    if (ImGui::CollapsingHeader("keys")) {
        ImGui::TextUnformatted("WASD move, Q/E down/up, Shift faster, right drag or arrows look");
        ImGui::TextUnformatted("left click: crater   Tab/F: draw mode   F12/P: screenshot");
        ImGui::TextUnformatted("Esc: quit");
    }
    ImGui::Text("%s", v.renderer.c_str());
    ImGui::End();

    ImGui::Render();
    ImGui_ImplOpenGL3_RenderDrawData(ImGui::GetDrawData());
}

} // namespace terrain::viewer
