#pragma once

// Keyboard and mouse, read from GLFW once per frame, turned into the fly camera's input and the
// viewer's actions. The overlay gets first claim: while ImGui wants the mouse (a slider is
// dragged) or the keyboard, the terrain sees none of it.
//
//   W/S A/D        forward/back, strafe       Q/E or Ctrl/Space   down/up    Shift   faster
//   right drag     look (cursor captured)      arrows              look
//   left click     crater at the ray hit       Tab or F            cycle draw mode
//   F12 or P       screenshot                  Esc                 quit

#include <terrain/viewer/fly_camera.h>

#include <vector>

struct GLFWwindow;

namespace terrain::viewer {

struct FrameInput {
    FlyInput fly;
    bool quit = false;
    bool cycle_draw_mode = false;
    bool screenshot = false;
    bool crater = false;   ///< left click on the terrain
    double crater_x = 0.0; ///< framebuffer pixels, origin top-left
    double crater_y = 0.0;
};

class WindowInput {
  public:
    explicit WindowInput(GLFWwindow* window);

    /// Call after glfwPollEvents(). `dt_seconds` scales the arrow keys' turning.
    FrameInput read(double dt_seconds, bool overlay_wants_mouse, bool overlay_wants_keyboard);

    /// Radians of turn per pixel of mouse movement.
    double mouse_sensitivity = 0.003;
    /// Radians per second of turn on the arrow keys.
    double key_turn_rate = 1.5;

  private:
    bool down(int key) const;
    /// True once per press (sticky keys catch a tap shorter than a frame).
    bool pressed(int key);

    GLFWwindow* window_;
    std::vector<unsigned char> was_down_;
    bool looking_ = false;
    double last_x_ = 0.0;
    double last_y_ = 0.0;
    bool left_was_down_ = false;
};

} // namespace terrain::viewer
