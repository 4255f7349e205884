/// @file gl_window.h
/// @brief A window with an OpenGL 3.3 core context and its input events. gl_window.cpp is the only
/// file that includes GLFW.
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "render/gl_api.h"

namespace aoscan {

/// The keys the live view reacts to.
enum class Key { kR, kSpace, kS, kV, kQ, kEscape };

struct WindowOptions {
  int width = 1280;
  int height = 720;
  std::string title = "aoscan";
  bool visible = true;  ///< false: a hidden window, only for its context (tests)
};

/// Input since the last poll.
struct WindowEvents {
  std::vector<Key> keys;    ///< presses, in order
  double drag_dx_px = 0.0;  ///< cursor motion with the left button held (screen pixels)
  double drag_dy_px = 0.0;
  double scroll = 0.0;           ///< wheel steps, positive away from the user
  bool close_requested = false;  ///< the user closed the window (window manager's close)
  /// The window was exposed or resized: what it shows must be drawn again.
  bool damaged = false;
  /// The connection to the display broke (X server gone, client killed): nothing more can be
  /// drawn; the window should be dropped.
  bool display_lost = false;
};

/// Owns GLFW (initialised by create(), terminated by the destructor): one window per process at a
/// time, created, used and destroyed on one thread.
///
/// A display that goes away while the window is open must not end the process (Xlib's default
/// I/O error handling calls exit()): create() installs X I/O error handlers that only mark the
/// display as lost, poll_events() then reports display_lost, and the destructor releases what it
/// can without talking to the dead server.
class GlWindow {
 public:
  /// Opens the window, makes its context current on this thread and loads the GL functions. Returns
  /// nullptr with a one-line `error` when there is no display, GLFW cannot start, the context is
  /// older than 3.3 core or a GL function is missing. Never throws for those.
  static std::unique_ptr<GlWindow> create(const WindowOptions& options, std::string& error);
  ~GlWindow();
  GlWindow(const GlWindow&) = delete;
  GlWindow& operator=(const GlWindow&) = delete;

  const GlApi& gl() const;
  /// Waits up to `timeout_s` for input (0: just polls), then returns what happened.
  WindowEvents poll_events(double timeout_s);
  /// Framebuffer size in pixels.
  void framebuffer_size(int& width, int& height) const;
  void swap_buffers();
  /// The renderer string of the context, e.g. "llvmpipe (LLVM 15.0.6, 256 bits)".
  std::string renderer() const;
  /// True once the connection to the display broke (see WindowEvents::display_lost).
  bool display_lost() const;
  /// The display's name, e.g. ":99" (for messages).
  const std::string& display_name() const;

  struct Impl;

 private:
  explicit GlWindow(std::unique_ptr<Impl> impl);
  std::unique_ptr<Impl> impl_;
};

}  // namespace aoscan
