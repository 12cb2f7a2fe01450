#include "window_input.h"

#include <GLFW/glfw3.h>

namespace terrain::viewer {

WindowInput::WindowInput(GLFWwindow* window)
    : window_(window), was_down_(static_cast<std::size_t>(GLFW_KEY_LAST) + 1, 0) {
    glfwSetInputMode(window_, GLFW_STICKY_KEYS, GLFW_TRUE);
    glfwSetInputMode(window_, GLFW_STICKY_MOUSE_BUTTONS, GLFW_TRUE);
}

bool WindowInput::down(int key) const {
    return glfwGetKey(window_, key) == GLFW_PRESS;
}

bool WindowInput::pressed(int key) {
    const bool now = down(key);
    unsigned char& was = was_down_[static_cast<std::size_t>(key)];
    const bool edge = now && was == 0;
    was = now ? 1 : 0;
    return edge;
}

FrameInput WindowInput::read(double dt, bool overlay_wants_mouse, bool overlay_wants_keyboard) {
    FrameInput in;
    // edges are tracked every frame, so a key held while the overlay had the keyboard is not
    // taken for a new press when it lets go
    const bool escape = pressed(GLFW_KEY_ESCAPE);
    const bool tab = pressed(GLFW_KEY_TAB);
    const bool f = pressed(GLFW_KEY_F);
    const bool f12 = pressed(GLFW_KEY_F12);
    const bool p = pressed(GLFW_KEY_P);
    if (!overlay_wants_keyboard) {
        const auto axis = [this](int plus, int minus) {
            return (down(plus) ? 1.0 : 0.0) - (down(minus) ? 1.0 : 0.0);
        };
        in.fly.forward = axis(GLFW_KEY_W, GLFW_KEY_S);
        in.fly.right = axis(GLFW_KEY_D, GLFW_KEY_A);
        in.fly.up = axis(GLFW_KEY_E, GLFW_KEY_Q) + axis(GLFW_KEY_SPACE, GLFW_KEY_LEFT_CONTROL);
        in.fly.fast = down(GLFW_KEY_LEFT_SHIFT) || down(GLFW_KEY_RIGHT_SHIFT);
        in.fly.yaw = key_turn_rate * dt * axis(GLFW_KEY_LEFT, GLFW_KEY_RIGHT);
        in.fly.pitch = key_turn_rate * dt * axis(GLFW_KEY_UP, GLFW_KEY_DOWN);
        in.quit = escape;
        in.cycle_draw_mode = tab || f;
        in.screenshot = f12 || p;
    }

    double x = 0.0;
    double y = 0.0;
    glfwGetCursorPos(window_, &x, &y);
    const bool right = glfwGetMouseButton(window_, GLFW_MOUSE_BUTTON_RIGHT) == GLFW_PRESS;
    if (right && !looking_ && !overlay_wants_mouse) {
        // capture the cursor so a drag can turn without limit
        looking_ = true;
        glfwSetInputMode(window_, GLFW_CURSOR, GLFW_CURSOR_DISABLED);
        glfwGetCursorPos(window_, &x, &y);
    } else if (looking_ && right) {
        in.fly.yaw -= (x - last_x_) * mouse_sensitivity;
        in.fly.pitch -= (y - last_y_) * mouse_sensitivity;
    } else if (looking_ && !right) {
        looking_ = false;
        glfwSetInputMode(window_, GLFW_CURSOR, GLFW_CURSOR_NORMAL);
    }
    last_x_ = x;
    last_y_ = y;

    const bool left = glfwGetMouseButton(window_, GLFW_MOUSE_BUTTON_LEFT) == GLFW_PRESS;
    if (left && !left_was_down_ && !overlay_wants_mouse && !looking_) {
        // cursor positions are in window coordinates; the camera's viewport is the framebuffer
        int window_w = 0;
        int window_h = 0;
        int fb_w = 0;
        int fb_h = 0;
        glfwGetWindowSize(window_, &window_w, &window_h);
        glfwGetFramebufferSize(window_, &fb_w, &fb_h);
        if (window_w > 0 && window_h > 0) {
            in.crater = true;
            in.crater_x = x * fb_w / window_w;
            in.crater_y = y * fb_h / window_h;
        }
    }
    left_was_down_ = left;
    return in;
}

} // namespace terrain::viewer
