/// @file live_view.cpp
/// @brief The live view's loop: events, keys, orbit camera, upload, draw, HUD.
#include "render/live_view.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <exception>
#include <optional>

#include "core/log.h"
#include "render/hud.h"

namespace aoscan {

bool software_renderer(const std::string& gl_renderer) {
  for (const char* name : {"llvmpipe", "softpipe", "swrast", "SwiftShader", "Software Rasterizer"})
    if (gl_renderer.find(name) != std::string::npos) return true;
  return false;
}

namespace {

using Clock = std::chrono::steady_clock;

/// Radians of orbit per pixel of drag, and zoom factor per wheel step.
constexpr float kOrbitRadPerPx = 0.01f;
constexpr float kZoomPerStep = 0.9f;

LiveViewResult unavailable(const std::string& why) {
  spdlog::warn("live view unavailable: {}; continuing headless", why);
  LiveViewResult result;
  result.outcome = LiveViewResult::Outcome::kUnavailable;
  result.message = why;
  return result;
}

LiveViewResult run_loop(const LiveViewOptions& options, const ViewFeed& feed,
                        ViewCommandQueue& commands, const std::atomic<bool>& stop) {
  std::string error;
  std::unique_ptr<GlWindow> window = GlWindow::create(options.window, error);
  if (!window) return unavailable(error);
  LiveViewResult result;
  result.gl_renderer = window->renderer();
  spdlog::info("live view open on {} ({})", window->display_name(), result.gl_renderer);
  {
    GlViewRenderer renderer;  // destroyed before the window, while its context is current
    if (!renderer.init(window->gl(), error, options.shader_overrides)) return unavailable(error);
    const GlApi& gl = window->gl();
    LiveViewState state;
    state.view = options.initial_view;
    OrbitCamera orbit;
    bool orbit_moved_by_user = false;
    const TriangleMesh* fitted_surface = nullptr;
    std::shared_ptr<const ViewFrame> shown;
    std::optional<View> uploaded_view;  ///< the view whose data of `shown` is uploaded
    Image<Rgba8> hud;
    double draw_fps = 0.0;
    Clock::time_point last_draw = Clock::now();
    const double wait_s = options.max_redraw_hz > 0 ? 1.0 / options.max_redraw_hz : 0.0;
    const double frame_interval_s =
        software_renderer(result.gl_renderer) && options.software_max_frame_hz > 0
            ? 1.0 / options.software_max_frame_hz
            : 0.0;

    while (!stop.load()) {
      const WindowEvents events = window->poll_events(wait_s);
      if (events.display_lost) {
        result.outcome = LiveViewResult::Outcome::kDisplayLost;
        result.message = "the display " + window->display_name() + " closed";
        break;
      }
      for (const Key key : events.keys) {
        handle_key(key, state, commands);
        if (key == Key::kR) orbit_moved_by_user = false;  // refit to the new model
      }
      if (state.quit) {
        result.outcome = LiveViewResult::Outcome::kQuit;
        break;
      }
      if (events.close_requested) {
        commands.push(ViewCommand::kQuit);
        result.outcome = LiveViewResult::Outcome::kQuit;
        break;
      }
      if (events.drag_dx_px != 0.0 || events.drag_dy_px != 0.0 || events.scroll != 0.0) {
        orbit.yaw_rad += kOrbitRadPerPx * static_cast<float>(events.drag_dx_px);
        orbit.pitch_rad =
            std::clamp(orbit.pitch_rad + kOrbitRadPerPx * static_cast<float>(events.drag_dy_px),
                       -kOrbitMaxPitchRad, kOrbitMaxPitchRad);
        orbit.distance_m *= std::pow(kZoomPerStep, static_cast<float>(events.scroll));
        orbit_moved_by_user = true;
      }

      bool changed = !events.keys.empty() || events.drag_dx_px != 0.0 || events.drag_dy_px != 0.0 ||
                     events.scroll != 0.0 || events.damaged;
      const bool frame_due =
          !shown ||
          std::chrono::duration<double>(Clock::now() - last_draw).count() >= frame_interval_s;
      std::shared_ptr<const ViewFrame> latest = feed && frame_due ? feed() : nullptr;
      if (latest && latest != shown) {
        shown = std::move(latest);
        uploaded_view.reset();
      }
      if (shown && uploaded_view != state.view) {  // a new frame, or another view of it
        renderer.upload(*shown, state.view);
        uploaded_view = state.view;
        changed = true;
      }
      if (!changed && result.redraws > 0 &&
          std::chrono::duration<double>(Clock::now() - last_draw).count() < options.idle_redraw_s)
        continue;
      if (shown && shown->surface && shown->surface.get() != fitted_surface &&
          !orbit_moved_by_user) {
        orbit = fit_orbit(*shown->surface);
        fitted_surface = shown->surface.get();
      }

      int width = 0;
      int height = 0;
      window->framebuffer_size(width, height);
      gl.BindFramebuffer(GL_FRAMEBUFFER, 0);
      gl.Viewport(0, 0, width, height);
      const Rgb8 bg = options.style.background;
      gl.ClearColor(bg.r / 255.0f, bg.g / 255.0f, bg.b / 255.0f, 1.0f);
      gl.Clear(GL_COLOR_BUFFER_BIT);
      if (shown) {
        const GlRect rect =
            orbit_camera_view(state.view)
                ? GlRect{0, 0, width, height}
                : letterbox(renderer.frame_width(), renderer.frame_height(), width, height);
        renderer.draw(state.view, rect, options.style, orbit);
      }
      render_text_overlay(hud_lines(shown.get(), state.view, draw_fps), options.hud_scale, hud);
      renderer.draw_overlay(hud, 8, 8, height);
      window->swap_buffers();
      ++result.redraws;

      const Clock::time_point now = Clock::now();
      const double dt = std::chrono::duration<double>(now - last_draw).count();
      last_draw = now;
      if (dt > 0) draw_fps = draw_fps == 0.0 ? 1.0 / dt : 0.9 * draw_fps + 0.1 / dt;
      if (options.max_redraws > 0 && result.redraws >= options.max_redraws) break;
    }
    // Stopped at the run's end: a display that went away before it is still reported, also when
    // this low-priority thread did not get to run between the loss and the stop.
    if (result.outcome == LiveViewResult::Outcome::kStopped &&
        window->poll_events(0.0).display_lost) {
      result.outcome = LiveViewResult::Outcome::kDisplayLost;
      result.message = "the display " + window->display_name() + " closed";
    }
  }
  if (result.outcome == LiveViewResult::Outcome::kDisplayLost)
    spdlog::warn("live view lost: {}; continuing headless", result.message);
  return result;
}

}  // namespace

void handle_key(Key key, LiveViewState& state, ViewCommandQueue& commands) {
  switch (key) {
    case Key::kR:
      commands.push(ViewCommand::kResetModel);
      break;
    case Key::kSpace:
      state.paused = !state.paused;
      commands.push(state.paused ? ViewCommand::kPauseIntegration
                                 : ViewCommand::kResumeIntegration);
      break;
    case Key::kS:
      commands.push(ViewCommand::kWriteOutputs);
      break;
    case Key::kV:
      state.view = next_view(state.view);
      break;
    case Key::kQ:
    case Key::kEscape:
      state.quit = true;
      commands.push(ViewCommand::kQuit);
      break;
  }
}

LiveViewResult run_live_view(const LiveViewOptions& options, const ViewFeed& feed,
                             ViewCommandQueue& commands, const std::atomic<bool>& stop) {
  try {
    return run_loop(options, feed, commands, stop);
  } catch (const std::exception& e) {  // e.g. out of memory while uploading
    return unavailable(e.what());
  }
}

}  // namespace aoscan
