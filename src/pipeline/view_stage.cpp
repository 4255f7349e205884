/// @file view_stage.cpp
/// @brief The view stage: ViewFrames for the window and the snapshots.
#include "pipeline/view_stage.h"

#include <algorithm>
#include <utility>

#include "core/log.h"

namespace aoscan {
namespace {

using Clock = std::chrono::steady_clock;

constexpr std::size_t kFpsWindow = 30;  ///< frames over which the HUD's fps is measured
constexpr double kMsSmoothing = 0.2;    ///< weight of the newest frame in the HUD's stage times

}  // namespace

ViewStage::ViewStage(ViewStageOptions options)
    : options_(std::move(options)), cloud_(options_.surface), publish_(options_.publish) {
  if (options_.snapshots) snapshots_.emplace(*options_.snapshots);
}

double ViewStage::recent_fps(Clock::time_point now) {
  done_times_.push_back(now);
  if (done_times_.size() > kFpsWindow) done_times_.pop_front();
  if (done_times_.size() < 2) return 0.0;
  const double span_s =
      std::chrono::duration<double>(done_times_.back() - done_times_.front()).count();
  return span_s > 0 ? static_cast<double>(done_times_.size() - 1) / span_s : 0.0;
}

void ViewStage::set_views(const std::vector<View>& views) {
  if (options_.publish_all_views) return;
  const auto watched = [&views](View v) {
    return std::find(views.begin(), views.end(), v) != views.end();
  };
  surface_wanted_.store(watched(View::kOrbit) || watched(View::kSplats));
  if (options_.on_colour_needed)
    options_.on_colour_needed(watched(View::kColour) || watched(View::kColourMvao));
}

void ViewStage::fill(const FrameWork& frame, ViewFrame& view) {
  view.sequence = frame.raw.sequence;
  view.timestamp_s = frame.raw.timestamp_s;
  view.T_world_camera = frame.fusion.T_world_camera;
  view.intrinsics = frame.raw.intrinsics;
  const RaycastResult* raycast = frame.raycast.get();
  // At the model raycast's resolution (the view enlarges them): copies into reused buffers.
  static const Image<float> kNoFloat;
  static const Image<Eigen::Vector3f> kNoVector;
  view.depth_m = raycast ? raycast->depth_m : kNoFloat;
  view.normals = raycast ? raycast->maps.normals : kNoVector;
  view.ssao = frame.ssao;
  view.mvao = frame.mvao;
  view.colour = frame.model_colour;
  view.raw_depth_m = frame.pre.depth_m;
  if (frame.fusion.status == TrackingStatus::kLost)
    view.tracking_state = kTrackingLostState;
  else if (frame.integration_paused)
    view.tracking_state = "paused";
  else
    view.tracking_state = to_string(frame.fusion.status);

  HudStats& hud = view.hud;
  hud.fps = recent_fps(Clock::now());
  // The view stage's own time is not known yet: the HUD shows the stages before it.
  const std::size_t shown = std::min(frame.stage_ms.size(), options_.stage_names.size());
  if (smoothed_ms_.size() != shown) smoothed_ms_.assign(shown, -1.0);
  hud.stage_ms.resize(shown);
  for (std::size_t i = 0; i < shown; ++i) {
    double& s = smoothed_ms_[i];
    s = s < 0 ? frame.stage_ms[i] : (1.0 - kMsSmoothing) * s + kMsSmoothing * frame.stage_ms[i];
    hud.stage_ms[i].first = options_.stage_names[i];
    hud.stage_ms[i].second = s;
  }
  hud.frames_processed = frames_seen_.load();
  hud.frames_dropped = frame.frames_dropped_before;
  hud.integration_paused = frame.integration_paused;
  view.surface = surface_;
}

std::shared_ptr<const ViewFrame> ViewStage::take_latest() {
  auto latest = mailbox_.latest();
  if (!latest) return nullptr;
  taken_version_.store(latest->second);
  return latest->first;
}

Status ViewStage::process(FrameWork& frame) {
  ++frames_seen_;
  if (!frame.view_products) return Status::ok();
  // Counted on the way out, after the product is published: caught_up() compares the mailbox
  // version with the window's, so an arrival must never be seen before its product.
  struct CountOnExit {
    std::atomic<std::uint64_t>& count;
    ~CountOnExit() { ++count; }
  } arrival{products_arrived_};
  if (!active()) return Status::ok();

  // The orbit cloud follows the model: a reset starts it over.
  if (frame.model_reset) {
    cloud_.clear();
    surface_.reset();
  }
  if (frame.raycast) cloud_.add(frame.raycast->maps, frame.mvao, frame.fusion.T_world_camera);
  ++frames_since_surface_;
  if (surface_wanted_.load() &&
      (!surface_ || frames_since_surface_ >= static_cast<std::size_t>(options_.surface_every))) {
    surface_ = cloud_.to_mesh();
    frames_since_surface_ = 0;
  }

  std::shared_ptr<ViewFrame> view = pool_.acquire();
  fill(frame, *view);
  std::shared_ptr<const ViewFrame> product = std::move(view);
  if (publish_.load()) mailbox_.put(product);
  if (snapshots_) {
    const std::size_t before = snapshots_->files_written();
    const Status status = snapshots_->offer(*product);
    snapshot_files_.fetch_add(snapshots_->files_written() - before);
    if (!status.is_ok()) {
      spdlog::warn("snapshots stopped: {}", status.message());
      snapshots_.reset();
    }
  }
  last_ = std::move(product);
  return Status::ok();
}

void ViewStage::finish(std::shared_ptr<const TriangleMesh> surface) {
  if (!snapshots_ || !last_) return;
  std::shared_ptr<ViewFrame> view = pool_.acquire();
  *view = *last_;
  if (surface && !surface->empty()) view->surface = std::move(surface);
  const std::size_t before = snapshots_->files_written();
  const Status status = snapshots_->write(*view);
  snapshot_files_.fetch_add(snapshots_->files_written() - before);
  if (!status.is_ok()) spdlog::warn("final snapshots failed: {}", status.message());
}

}  // namespace aoscan
