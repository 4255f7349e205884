/// @file tum_source.cpp
/// @brief TUM RGB-D folder reader: list, calibration and ground truth on open, one PNG per read().
#include "capture/tum_source.h"

#include <algorithm>
#include <filesystem>
#include <utility>
#include <vector>

#include <spdlog/spdlog.h>

#include "capture/png_depth.h"
#include "io/camera_json.h"
#include "io/colour_image.h"
#include "io/tum.h"

namespace aoscan {
namespace {

namespace fs = std::filesystem;

/// `folder` without trailing separators ("/" stays "/").
std::string trimmed(std::string folder) {
  while (folder.size() > 1 && folder.back() == '/') folder.pop_back();
  return folder;
}

bool is_file(const std::string& path) {
  std::error_code ec;
  return fs::is_regular_file(path, ec);
}

class TumSource final : public Source {
 public:
  explicit TumSource(const std::string& folder) : folder_(trimmed(folder)) {
    std::error_code ec;
    if (!folder_.empty() && fs::exists(folder_, ec) && !fs::is_directory(folder_, ec))
      throw input_error(folder_ + ": is a file, not a recording folder (a TUM-layout folder "
                        "holds depth.txt and the depth PNGs it lists)");
    if (folder_.empty() || !fs::is_directory(folder_, ec))
      throw input_error(folder_ + ": no such folder");

    const std::string list = folder_ + "/depth.txt";
    if (!is_file(list))
      throw input_error(list + ": missing (a TUM-layout folder lists its depth PNGs there)");
    entries_ = read_tum_list(list);
    if (entries_.empty()) throw input_error(list + ": lists no frames");
    paths_.reserve(entries_.size());
    for (const TumListEntry& e : entries_)
      paths_.push_back(fs::path(e.path).is_absolute() ? e.path : folder_ + "/" + e.path);

    const std::string camera = folder_ + "/camera.json";
    CameraInfo info =
        is_file(camera) ? read_camera_json(camera, 0, 0) : default_camera_for_folder(folder_);
    intrinsics_ = info.intrinsics;
    depth_scale_ = info.depth_scale;
    size_known_ = info.size_given;
    size_origin_ = info.size_given ? "camera.json" : "first frame";
    calibration_origin_ = info.origin;
    calibration_is_default_ = info.is_default;

    const std::string gt = folder_ + "/groundtruth.txt";
    if (is_file(gt)) {
      ground_truth_ = read_trajectory(gt);
      std::stable_sort(
          ground_truth_.begin(), ground_truth_.end(),
          [](const StampedPose& a, const StampedPose& b) { return a.timestamp_s < b.timestamp_s; });
    }

    if (!size_known_) probe_size();
    open_colour(info);
    // A camera.json of a camera that cannot exist (the defaults stand for 640x480 cameras).
    if (is_file(camera))
      if (const std::string why = intrinsics_.implausible(); !why.empty())
        throw input_error(camera + ": " + why);
  }

  Status read(DepthFrame& frame) override {
    if (next_ >= entries_.size()) return Status::end_of_stream();
    const std::size_t i = next_++;
    try {
      const std::string& path = paths_[i];
      if (probe_valid_ && i == probe_index_) {
        std::swap(frame.depth, probe_image_);  // decoded on open; not decoded twice
        probe_valid_ = false;
      } else if (Status s = read_depth_png(path, frame.depth, i); !s.is_ok()) {
        return s;
      }
      if (!size_known_) {
        intrinsics_.width = frame.depth.width();
        intrinsics_.height = frame.depth.height();
        size_known_ = true;
      } else if (frame.depth.width() != intrinsics_.width ||
                 frame.depth.height() != intrinsics_.height) {
        return Status::corrupt_frame(
            path + " (frame " + std::to_string(i) + "): size " +
            size_text(frame.depth.width(), frame.depth.height()) + " differs from " +
            size_text(intrinsics_.width, intrinsics_.height) + " of the " + size_origin_);
      }
      frame.depth_scale = depth_scale_;
      frame.intrinsics = intrinsics_;
      frame.timestamp_s = entries_[i].timestamp_s;
      frame.sequence = i;
      frame.origin = path;
      frame.T_world_camera_gt = associate(ground_truth_, frame.timestamp_s, kGroundTruthMaxDtS);
      read_colour(i, frame);
      return Status::ok();
    } catch (const std::exception& e) {
      return Status::internal(paths_[i] + " (frame " + std::to_string(i) + "): " + e.what());
    }
  }

  std::string name() const override { return folder_; }
  const Intrinsics& intrinsics() const override { return intrinsics_; }
  double depth_scale() const override { return depth_scale_; }
  std::string calibration_origin() const override { return calibration_origin_; }
  bool calibration_is_default() const override { return calibration_is_default_; }
  std::string colour_origin() const override { return colour_origin_; }
  std::optional<std::size_t> size() const override { return entries_.size(); }
  bool seekable() const override { return true; }
  Status seek(std::size_t index) override {
    if (index >= entries_.size())
      return Status::internal(folder_ + ": cannot seek to frame " + std::to_string(index) +
                              " of " + std::to_string(entries_.size()));
    next_ = index;
    return Status::ok();
  }

 private:
  /// rgb.txt, when the folder has one: its entries paired with depth.txt's (associate_lists()),
  /// the colour camera from camera.json or, without one there, colour taken as registered. A
  /// list that cannot be read leaves the recording without colour (the depth is never lost).
  void open_colour(const CameraInfo& info) {
    const std::string list = folder_ + "/rgb.txt";
    if (!is_file(list)) return;
    std::vector<TumListEntry> colour;
    try {
      colour = read_tum_list(list);
    } catch (const Error& e) {
      spdlog::warn("{}; the recording is replayed without colour", e.what());
      return;
    }
    if (colour.empty()) {
      spdlog::warn("{}: lists no frames; the recording is replayed without colour", list);
      return;
    }
    const std::vector<std::optional<std::size_t>> partner =
        associate_lists(entries_, colour, kColourMaxDtS);
    colour_paths_.resize(entries_.size());
    colour_stamps_.resize(entries_.size());
    for (std::size_t i = 0; i < entries_.size(); ++i) {
      if (!partner[i]) continue;
      const TumListEntry& e = colour[*partner[i]];
      colour_paths_[i] = fs::path(e.path).is_absolute() ? e.path : folder_ + "/" + e.path;
      colour_stamps_[i] = e.timestamp_s;
    }
    if (info.colour) {
      colour_camera_ = *info.colour;
      if (colour_camera_->registered) colour_camera_->intrinsics = intrinsics_;
      colour_origin_ = info.origin;
    } else {
      colour_camera_ = ColourCamera::registered_to(intrinsics_);
      colour_origin_ = "assumed registered (no colour camera in camera.json)";
      spdlog::warn("{}: colour without a colour camera in camera.json: taken as registered to "
                   "the depth (aoscan-colour-registration estimates the registration)",
                   folder_);
    }
  }

  /// Frame i's colour into `frame`, or the reason it has none in frame.colour_error.
  void read_colour(std::size_t i, DepthFrame& frame) {
    frame.colour_camera = colour_camera_;
    frame.colour_error.clear();
    frame.colour_timestamp_s = 0.0;
    if (!colour_camera_ || !colour_wanted(i)) {
      frame.colour.resize(0, 0);
      return;
    }
    const auto fail = [&](std::string why) {
      frame.colour.resize(0, 0);
      frame.colour_error = std::move(why);
    };
    if (colour_paths_[i].empty())
      return fail(paths_[i] + " (frame " + std::to_string(i) + "): no colour frame within " +
                  std::to_string(static_cast<int>(kColourMaxDtS * 1000.0 + 0.5)) +
                  " ms in rgb.txt");
    // A frame of another size than the colour camera's is refused before it is decoded.
    const Intrinsics& k = colour_camera_->intrinsics;
    if (Status s = read_colour_image(colour_paths_[i], frame.colour, i,
                                     ExpectedSize{k.width, k.height});
        !s.is_ok())
      return fail(s.message());
    frame.colour_timestamp_s = colour_stamps_[i];
  }

  /// Without a size in camera.json, the first frame that decodes sets it; it is kept for read().
  void probe_size() {
    for (std::size_t i = 0; i < paths_.size(); ++i) {
      if (read_depth_png(paths_[i], probe_image_).is_ok()) {
        intrinsics_.width = probe_image_.width();
        intrinsics_.height = probe_image_.height();
        size_known_ = true;
        probe_index_ = i;
        probe_valid_ = true;
        return;
      }
    }
    // No frame decodes: every read() reports its corrupt frame; keep a nominal size meanwhile.
    intrinsics_.width = 640;
    intrinsics_.height = 480;
  }

  std::string folder_;
  std::vector<TumListEntry> entries_;
  std::vector<std::string> paths_;  ///< PNG path of each entry, resolved against the folder
  Intrinsics intrinsics_;
  double depth_scale_ = 0.0;
  bool size_known_ = false;
  std::string size_origin_;
  std::string calibration_origin_;
  bool calibration_is_default_ = false;
  std::vector<StampedPose> ground_truth_;  ///< sorted by timestamp
  std::size_t next_ = 0;
  Image<std::uint16_t> probe_image_;
  std::size_t probe_index_ = 0;
  bool probe_valid_ = false;
  // Colour (when the folder has rgb.txt): per depth entry its colour image ("" = none near it).
  std::optional<ColourCamera> colour_camera_;
  std::string colour_origin_;
  std::vector<std::string> colour_paths_;
  std::vector<double> colour_stamps_;
};

}  // namespace

std::unique_ptr<Source> open_tum_folder(const std::string& folder) {
  return std::make_unique<TumSource>(folder);
}

}  // namespace aoscan
