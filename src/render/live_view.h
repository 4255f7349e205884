/// @file live_view.h
/// @brief The live view: a window showing the latest ViewFrame in one of five views with a HUD,
/// turning keys into ViewCommands. A run-loop function for a thread the pipeline owns.
///
/// Wiring (pipeline owner):
///   Mailbox<std::shared_ptr<const ViewFrame>> mailbox;   // put() by the last stage
///   ViewCommandQueue commands;                           // polled by the pipeline
///   std::thread t([&] { run_live_view(options,
///       [&] { auto v = mailbox.latest(); return v ? v->first : nullptr; }, commands, stop); });
/// The view only takes shared pointers to immutable frames, so it never slows fusion down.
#pragma once

#include <atomic>
#include <functional>
#include <memory>
#include <string>

#include "render/composite.h"
#include "render/gl_renderer.h"
#include "render/gl_window.h"
#include "render/view_commands.h"
#include "render/view_frame.h"

namespace aoscan {

/// The newest frame (or null before the first); called from the render thread, must be cheap.
using ViewFeed = std::function<std::shared_ptr<const ViewFrame>()>;

struct LiveViewOptions {
  WindowOptions window;
  ViewStyle style;
  View initial_view = View::kShaded;
  int hud_scale = 2;            ///< HUD font magnification
  double max_redraw_hz = 60.0;  ///< the loop waits for input between redraws at most this often
  /// The window is drawn again when a new frame arrives, on input or damage, and otherwise every
  /// idle_redraw_s (0: on every pass of the loop). Redrawing an unchanged picture would only take
  /// CPU from fusion (the software renderer shares its cores).
  double idle_redraw_s = 0.5;
  /// With a software GL renderer (software_renderer()), a new frame is taken at most this often
  /// (0 = as they come); input still redraws at once. Such a renderer draws on the CPU cores
  /// that fusion needs, and the demand-driven view products follow the frames taken.
  double software_max_frame_hz = 0.0;
  /// Test hooks: replacement shader sources, and a redraw count after which the loop returns
  /// kStopped (0 = no limit).
  ShaderOverrides shader_overrides;
  long max_redraws = 0;
};

struct LiveViewResult {
  enum class Outcome {
    kStopped,      ///< `stop` became true
    kQuit,         ///< q / Esc / window closed: kQuit was pushed
    kUnavailable,  ///< no window could be made (message says why); the run goes on headless
    kDisplayLost,  ///< the display went away while the window was open; the run goes on headless
  };
  Outcome outcome = Outcome::kStopped;
  std::string message;  ///< one line for kUnavailable and kDisplayLost
  long redraws = 0;
  std::string gl_renderer;  ///< GL_RENDERER of the context, when one was made
};

/// True for GL_RENDERER strings of renderers that draw on the CPU (Mesa's llvmpipe, softpipe
/// and swrast, SwiftShader).
bool software_renderer(const std::string& gl_renderer);

/// What the keys change inside the view itself.
struct LiveViewState {
  View view = View::kShaded;
  bool paused = false;  ///< integration paused (as last requested)
  bool quit = false;
};

/// Applies one key: r → kResetModel, space → kPause/kResumeIntegration (toggles state.paused),
/// s → kWriteOutputs, v → next view, q / Esc → kQuit (state.quit).
void handle_key(Key key, LiveViewState& state, ViewCommandQueue& commands);

/// Opens the window and redraws the newest frame until `stop` is set, the user quits (q, Esc or
/// closing the window: kQuit is pushed, like SIGINT), no window can be made (one warning line
/// "live view unavailable: ...; continuing headless", returns kUnavailable at once) or the display
/// goes away while the window is open (X server ended, connection killed: one warning line
/// "live view lost: ...; continuing headless", returns kDisplayLost; nothing is pushed, so the
/// run goes on). Logs "live view open on DISPLAY (renderer)" at info level when the window is up.
/// All GLFW and GL calls happen on the calling thread. Never throws.
LiveViewResult run_live_view(const LiveViewOptions& options, const ViewFeed& feed,
                             ViewCommandQueue& commands, const std::atomic<bool>& stop);

}  // namespace aoscan
