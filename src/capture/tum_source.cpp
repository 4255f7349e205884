/// @file tum_source.cpp
/// @brief TUM RGB-D folder reader: list, calibration and ground truth on open, one PNG per read().
#include "capture/tum_source.h"

#include <algorithm>
#include <filesystem>
#include <utility>
#include <vector>

#include "capture/png_depth.h"
#include "io/camera_json.h"
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

std::string size_text(int width, int height) {
  return std::to_string(width) + "x" + std::to_string(height);
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
};

}  // namespace

std::unique_ptr<Source> open_tum_folder(const std::string& folder) {
  return std::make_unique<TumSource>(folder);
}

}  // namespace aoscan
