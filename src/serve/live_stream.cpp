/// @file live_stream.cpp
/// @brief The live view frames for the service's viewers.
#include "serve/live_stream.h"

#include <algorithm>
#include <map>
#include <optional>

#include <spdlog/spdlog.h>

#include "core/host_cpu.h"
#include "io/colour_image.h"
#include "pipeline/view_stage.h"
#include "render/composite.h"

namespace aoscan {

nlohmann::json LiveFigures::to_json() const {
  if (!valid) return nullptr;
  // In the chain's order (capture first): a JSON object would sort them by name.
  nlohmann::json stages = nlohmann::json::array();
  for (const auto& [name, ms] : stage_ms) stages.push_back({{"stage", name}, {"ms", ms}});
  return {{"sequence", sequence},
          {"fps", fps},
          {"stage_ms", stages},
          {"frames_processed", frames_processed},
          {"frames_dropped", frames_dropped},
          {"integration_paused", integration_paused},
          {"tracking", tracking_state}};
}

View LiveViewer::view() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return view_;
}

void LiveViewer::set_view(View view) {
  std::lock_guard<std::mutex> lock(mutex_);
  view_ = view;
}

std::shared_ptr<const EncodedFrame> LiveViewer::next(std::chrono::milliseconds timeout) {
  std::unique_lock<std::mutex> lock(mutex_);
  changed_.wait_for(lock, timeout, [this] { return closed_ || pending_ != nullptr; });
  if (closed_ || !pending_) return nullptr;
  return std::exchange(pending_, nullptr);
}

void LiveViewer::close() {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    closed_ = true;
    pending_.reset();
  }
  changed_.notify_all();
}

bool LiveViewer::closed() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return closed_;
}

std::size_t LiveViewer::frames_skipped() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return skipped_;
}

void LiveViewer::offer(std::shared_ptr<const EncodedFrame> frame) {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    if (closed_ || frame->view != view_) return;
    if (pending_) ++skipped_;
    pending_ = std::move(frame);
  }
  changed_.notify_all();
}

LiveStream::LiveStream(LiveStreamOptions options) : options_(options) {
  thread_ = std::thread([this] { loop(); });
}

LiveStream::~LiveStream() {
  {
    std::lock_guard<std::mutex> lock(wake_mutex_);
    done_ = true;
  }
  wake_.notify_all();
  thread_.join();
  std::lock_guard<std::mutex> lock(mutex_);
  for (const auto& viewer : viewers_) viewer->close();
}

void LiveStream::attach(ViewStage* stage) {
  std::lock_guard<std::mutex> stage_lock(stage_mutex_);  // waits for a frame in use
  stage_ = stage;
  have_last_ = false;
  std::lock_guard<std::mutex> lock(mutex_);
  figures_ = LiveFigures{};
}

std::shared_ptr<LiveViewer> LiveStream::add_viewer(View view) {
  std::lock_guard<std::mutex> lock(mutex_);
  if (viewers_.size() >= options_.max_viewers) return nullptr;
  viewers_.push_back(std::make_shared<LiveViewer>(view));
  refresh();  // the newcomer gets the current frame at the next tick
  return viewers_.back();
}

void LiveStream::refresh() {
  resend_.store(true);
  wake_.notify_all();
}

void LiveStream::remove_viewer(const std::shared_ptr<LiveViewer>& viewer) {
  viewer->close();
  std::lock_guard<std::mutex> lock(mutex_);
  viewers_.erase(std::remove(viewers_.begin(), viewers_.end(), viewer), viewers_.end());
}

std::size_t LiveStream::viewers() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return viewers_.size();
}

LiveFigures LiveStream::figures() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return figures_;
}

std::size_t LiveStream::frames_encoded() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return frames_encoded_;
}

void LiveStream::pump() {
  std::lock_guard<std::mutex> stage_lock(stage_mutex_);
  if (!stage_) return;
  {
    // The views watched decide what the pipeline makes for them (the fused colour, the orbit
    // cloud): nothing for views nobody watches.
    std::vector<View> watched;
    std::lock_guard<std::mutex> lock(mutex_);
    for (const auto& viewer : viewers_) watched.push_back(viewer->view());
    stage_->set_views(watched);
  }
  std::shared_ptr<const ViewFrame> frame = stage_->take_latest();
  if (!frame) return;
  const bool resend = resend_.exchange(false);
  if (!resend && have_last_ && frame->sequence == last_sequence_) return;
  last_sequence_ = frame->sequence;
  have_last_ = true;

  std::vector<std::shared_ptr<LiveViewer>> viewers;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    LiveFigures& f = figures_;
    f.valid = true;
    f.sequence = frame->sequence;
    f.fps = frame->hud.fps;
    f.stage_ms = frame->hud.stage_ms;
    f.frames_processed = frame->hud.frames_processed;
    f.frames_dropped = frame->hud.frames_dropped;
    f.integration_paused = frame->hud.integration_paused;
    f.tracking_state = frame->tracking_state;
    viewers = viewers_;
  }
  // One encoding per view that someone watches.
  std::map<View, std::shared_ptr<const EncodedFrame>> encoded;
  Image<Rgb8> image;
  for (const auto& viewer : viewers) {
    const View view = viewer->view();
    auto it = encoded.find(view);
    if (it == encoded.end()) {
      auto out = std::make_shared<EncodedFrame>();
      out->view = view;
      out->sequence = frame->sequence;
      // At the model raycast's resolution (half the camera's by default): nothing of the
      // model's views is lost and a quarter of the pixels is composited, encoded and sent.
      composite_view(*frame, view, image, {}, model_scale(*frame));
      encode_colour_jpeg(image, options_.jpeg_quality, out->jpeg);
      it = encoded.emplace(view, std::move(out)).first;
      std::lock_guard<std::mutex> lock(mutex_);
      ++frames_encoded_;
    }
    viewer->offer(it->second);
  }
}

void LiveStream::loop() {
  // The stream yields the CPU to fusion, as the live window does: viewers get what it leaves.
  if (!lower_thread_priority(kViewerNice))
    spdlog::debug("serve: could not lower the live stream thread's priority");
  using Clock = std::chrono::steady_clock;
  Clock::time_point next = Clock::now();
  for (;;) {
    const double hz = viewers() > 0 ? options_.max_fps : options_.status_hz;
    next += std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(1.0 / hz));
    const Clock::time_point now = Clock::now();
    if (next < now) next = now;
    {
      std::unique_lock<std::mutex> lock(wake_mutex_);
      if (wake_.wait_until(lock, next, [this] { return done_; })) return;
    }
    try {
      pump();
    } catch (const std::exception& e) {  // an encoding failure costs a frame, never the service
      spdlog::warn("serve: live view frame: {}", e.what());
    }
  }
}

std::optional<View> view_named(const std::string& name) {
  for (int i = 0; i < kViewCount; ++i) {
    const View view = static_cast<View>(i);
    if (name == view_name(view)) return view;
  }
  return std::nullopt;
}

}  // namespace aoscan
