/// @file camera_file.cpp
/// @brief read_camera_file() and the source wrapper that applies it.
#include "capture/camera_file.h"

#include <optional>
#include <utility>

#include "core/log.h"

namespace aoscan {
namespace {

class CameraFileSource final : public Source {
 public:
  CameraFileSource(std::unique_ptr<Source> inner, CameraInfo camera, const std::string& path)
      : inner_(std::move(inner)), path_(path) {
    const Intrinsics& nominal = inner_->intrinsics();
    intrinsics_ = camera.intrinsics;
    if (!camera.size_given) {
      intrinsics_.width = nominal.width;
      intrinsics_.height = nominal.height;
    } else if (camera.intrinsics.width != nominal.width ||
               camera.intrinsics.height != nominal.height) {
      throw usage_error(path_ + ": a " + size_text(camera.intrinsics.width,
                                                   camera.intrinsics.height) +
                        " camera, but " + inner_->name() + " delivers " +
                        size_text(nominal.width, nominal.height) + " depth");
    }
    if (const std::string why = intrinsics_.implausible(); !why.empty())
      throw usage_error(path_ + ": " + why);
    depth_scale_ = camera.depth_scale;
    if (depth_scale_ != inner_->depth_scale())
      spdlog::warn("{}: depth_scale {} replaces the {} raw units per metre of {}", path_,
                   depth_scale_, inner_->depth_scale(), inner_->name());
    if (camera.colour) {
      colour_ = *camera.colour;
      if (colour_->registered) colour_->intrinsics = intrinsics_;
      if (inner_->colour_origin().empty())
        spdlog::warn("{}: {} has no colour; the colour camera in the file is not used", path_,
                     inner_->name());
    }
  }

  Status read(DepthFrame& frame) override {
    if (!forwarded_) {
      forward_settings(*inner_);
      forwarded_ = true;
    }
    const Status s = inner_->read(frame);
    if (!s.is_ok()) return s;
    // Frame origins are a file, a camera's name or already name the frame (synth:).
    const std::string where = frame.origin.find("frame ") != std::string::npos
                                  ? frame.origin
                                  : frame.origin + " (frame " + std::to_string(frame.sequence) + ")";
    if (frame.depth.width() != intrinsics_.width || frame.depth.height() != intrinsics_.height)
      return Status::corrupt_frame(where + ": " +
                                   size_text(frame.depth.width(), frame.depth.height()) +
                                   " depth differs from " +
                                   size_text(intrinsics_.width, intrinsics_.height) + " of " +
                                   path_);
    frame.intrinsics = intrinsics_;
    frame.depth_scale = depth_scale_;
    if (colour_ && frame.colour_camera) {
      frame.colour_camera = *colour_;
      const Intrinsics& k = colour_->intrinsics;
      if (!frame.colour.empty() && (frame.colour.width() != k.width ||
                                    frame.colour.height() != k.height)) {
        frame.colour_error = where + ": colour image of " +
                             size_text(frame.colour.width(), frame.colour.height()) +
                             " differs from " + size_text(k.width, k.height) +
                             " of the colour camera in " + path_;
        frame.colour.resize(0, 0);
      }
    }
    return Status::ok();
  }

  std::string name() const override { return inner_->name(); }
  const Intrinsics& intrinsics() const override { return intrinsics_; }
  double depth_scale() const override { return depth_scale_; }
  std::string calibration_origin() const override { return path_ + " (--camera)"; }
  std::string colour_origin() const override {
    const std::string inner = inner_->colour_origin();
    return inner.empty() || !colour_ ? inner : path_ + " (--camera)";
  }
  std::optional<std::size_t> size() const override { return inner_->size(); }
  bool live() const override { return inner_->live(); }
  bool seekable() const override { return inner_->seekable(); }
  Status seek(std::size_t index) override { return inner_->seek(index); }
  const TriangleMesh* scene_mesh() const override { return inner_->scene_mesh(); }

 private:
  std::unique_ptr<Source> inner_;
  std::string path_;
  Intrinsics intrinsics_;
  double depth_scale_ = 0.0;
  std::optional<ColourCamera> colour_;
  bool forwarded_ = false;
};

}  // namespace

CameraInfo read_camera_file(const std::string& path) {
  try {
    return read_camera_json(path, 0, 0);
  } catch (const Error& e) {
    throw usage_error(std::string("--camera ") + e.what());
  }
}

std::unique_ptr<Source> with_camera_file(std::unique_ptr<Source> inner, const CameraInfo& camera,
                                         const std::string& path) {
  return std::make_unique<CameraFileSource>(std::move(inner), camera, path);
}

}  // namespace aoscan
