/// @file gl_window.cpp
/// @brief GLFW: the window, its GL 3.3 core context, keyboard / mouse input, and surviving the
/// loss of the X display.
#include "render/gl_window.h"

#include <atomic>
#include <cstdlib>
#include <utility>

#define GLFW_INCLUDE_NONE  // GL types come from GL/glcorearb.h (gl_api.h)
#include <GLFW/glfw3.h>
// Last: Xlib's macros (Status, Bool, None, ...) must not reach any other header.
#define GLFW_EXPOSE_NATIVE_X11
#include <GLFW/glfw3native.h>

namespace aoscan {
namespace {

/// The last GLFW error on this thread (GLFW reports errors through a callback).
thread_local std::string t_glfw_error;

void on_glfw_error(int code, const char* description) {
  t_glfw_error = std::string(description ? description : "unknown error") + " (GLFW error " +
                 std::to_string(code) + ")";
}

void* get_proc(const char* name) {
  return reinterpret_cast<void*>(glfwGetProcAddress(name));
}

/// Set by Xlib's I/O error path when the connection to the display breaks. Process-wide like
/// GLFW itself (one window per process); cleared by create().
std::atomic<bool> g_display_lost{false};

/// Replaces Xlib's default I/O error handler, which prints several lines: the live view reports
/// the loss in one line of its own.
int on_x_io_error(Display*) {
  g_display_lost.store(true);
  return 0;
}

/// Replaces Xlib's exit() after an I/O error (libX11 >= 1.7): the connection stays marked as
/// broken, later calls on it return at once, and the process goes on.
void on_x_io_error_exit(Display*, void*) {
  g_display_lost.store(true);
}

}  // namespace

struct GlWindow::Impl {
  GLFWwindow* window = nullptr;
  std::string display_name;
  GlApi gl;
  WindowEvents events;
  bool dragging = false;
  double last_x = 0.0;
  double last_y = 0.0;

  static Impl& of(GLFWwindow* window) {
    return *static_cast<Impl*>(glfwGetWindowUserPointer(window));
  }
  static void on_key(GLFWwindow* window, int key, int, int action, int) {
    if (action != GLFW_PRESS) return;
    auto& keys = of(window).events.keys;
    switch (key) {
      case GLFW_KEY_R:
        keys.push_back(Key::kR);
        break;
      case GLFW_KEY_SPACE:
        keys.push_back(Key::kSpace);
        break;
      case GLFW_KEY_S:
        keys.push_back(Key::kS);
        break;
      case GLFW_KEY_V:
        keys.push_back(Key::kV);
        break;
      case GLFW_KEY_Q:
        keys.push_back(Key::kQ);
        break;
      case GLFW_KEY_ESCAPE:
        keys.push_back(Key::kEscape);
        break;
      default:
        break;
    }
  }
  static void on_button(GLFWwindow* window, int button, int action, int) {
    if (button != GLFW_MOUSE_BUTTON_LEFT) return;
    Impl& self = of(window);
    self.dragging = action == GLFW_PRESS;
    glfwGetCursorPos(window, &self.last_x, &self.last_y);
  }
  static void on_cursor(GLFWwindow* window, double x, double y) {
    Impl& self = of(window);
    if (self.dragging) {
      self.events.drag_dx_px += x - self.last_x;
      self.events.drag_dy_px += y - self.last_y;
    }
    self.last_x = x;
    self.last_y = y;
  }
  static void on_scroll(GLFWwindow* window, double, double dy) { of(window).events.scroll += dy; }
  static void on_refresh(GLFWwindow* window) { of(window).events.damaged = true; }
  static void on_resize(GLFWwindow* window, int, int) { of(window).events.damaged = true; }
};

std::unique_ptr<GlWindow> GlWindow::create(const WindowOptions& options, std::string& error) {
  glfwSetErrorCallback(on_glfw_error);
  t_glfw_error.clear();
  const char* display = std::getenv("DISPLAY");
  const char* wayland = std::getenv("WAYLAND_DISPLAY");
  if ((!display || !*display) && (!wayland || !*wayland)) {
    error = "no display (DISPLAY is not set)";
    return nullptr;
  }
  g_display_lost.store(false);
  XSetIOErrorHandler(on_x_io_error);
  if (!glfwInit()) {
    error = "GLFW cannot start: " + t_glfw_error;
    return nullptr;
  }
  Display* x_display = glfwGetX11Display();
  if (!x_display) {
    error = "GLFW has no X11 display";
    glfwTerminate();
    return nullptr;
  }
  XSetIOErrorExitHandler(x_display, on_x_io_error_exit, nullptr);
  glfwDefaultWindowHints();
  glfwWindowHint(GLFW_CONTEXT_VERSION_MAJOR, 3);
  glfwWindowHint(GLFW_CONTEXT_VERSION_MINOR, 3);
  glfwWindowHint(GLFW_OPENGL_PROFILE, GLFW_OPENGL_CORE_PROFILE);
  glfwWindowHint(GLFW_OPENGL_FORWARD_COMPAT, GLFW_TRUE);
  glfwWindowHint(GLFW_VISIBLE, options.visible ? GLFW_TRUE : GLFW_FALSE);
  GLFWwindow* window =
      glfwCreateWindow(options.width, options.height, options.title.c_str(), nullptr, nullptr);
  if (!window) {
    error = "cannot create an OpenGL 3.3 core context: " + t_glfw_error;
    glfwTerminate();
    return nullptr;
  }
  glfwMakeContextCurrent(window);
  auto impl = std::make_unique<Impl>();
  impl->window = window;
  impl->display_name = DisplayString(x_display);
  if (!impl->gl.load(get_proc, error) || impl->gl.version() < 33) {
    if (error.empty())
      error = "OpenGL 3.3 is needed, the context has " + std::to_string(impl->gl.version() / 10) +
              "." + std::to_string(impl->gl.version() % 10);
    glfwDestroyWindow(window);
    glfwTerminate();
    return nullptr;
  }
  glfwSwapInterval(1);
  glfwSetWindowUserPointer(window, impl.get());
  glfwSetKeyCallback(window, Impl::on_key);
  glfwSetMouseButtonCallback(window, Impl::on_button);
  glfwSetCursorPosCallback(window, Impl::on_cursor);
  glfwSetScrollCallback(window, Impl::on_scroll);
  glfwSetWindowRefreshCallback(window, Impl::on_refresh);
  glfwSetFramebufferSizeCallback(window, Impl::on_resize);
  return std::unique_ptr<GlWindow>(new GlWindow(std::move(impl)));
}

GlWindow::GlWindow(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}

GlWindow::~GlWindow() {
  glfwDestroyWindow(impl_->window);
  glfwTerminate();
}

const GlApi& GlWindow::gl() const {
  return impl_->gl;
}

WindowEvents GlWindow::poll_events(double timeout_s) {
  if (g_display_lost.load()) {  // nothing to wait for on a broken connection
    WindowEvents out;
    out.display_lost = true;
    return out;
  }
  if (timeout_s > 0.0) {
    glfwWaitEventsTimeout(timeout_s);
  } else {
    glfwPollEvents();
  }
  WindowEvents out = std::exchange(impl_->events, WindowEvents{});
  out.close_requested = glfwWindowShouldClose(impl_->window) != 0;
  out.display_lost = g_display_lost.load();
  return out;
}

void GlWindow::framebuffer_size(int& width, int& height) const {
  glfwGetFramebufferSize(impl_->window, &width, &height);
}

void GlWindow::swap_buffers() {
  if (!g_display_lost.load()) glfwSwapBuffers(impl_->window);
}

bool GlWindow::display_lost() const {
  return g_display_lost.load();
}

const std::string& GlWindow::display_name() const {
  return impl_->display_name;
}

std::string GlWindow::renderer() const {
  const GLubyte* name = impl_->gl.GetString(GL_RENDERER);
  return name ? reinterpret_cast<const char*>(name) : "unknown";
}

}  // namespace aoscan
