/// @file synth_source.cpp
/// @brief The `synth:` source: sim's analytic scenes rendered frame by frame along the built-in
/// trajectory, as a Source.
#include "capture/synth_source.h"

#include <exception>
#include <string>
#include <utility>

#include "core/status.h"

namespace aoscan {
namespace {

class SynthSource final : public Source {
 public:
  SynthSource(std::string spec, SynthParams params)
      : spec_(std::move(spec)),
        params_(std::move(params)),
        scene_(AnalyticScene::make(params_.scene)),
        intrinsics_(params_.intrinsics()),
        mesh_(scene_.to_mesh()),
        colour_(params_.colour) {}

  Status read(DepthFrame& frame) override {
    if (next_ >= static_cast<std::uint64_t>(params_.frames)) return Status::end_of_stream();
    try {
      const std::uint64_t index = next_++;
      params_.colour = colour_ && colour_wanted(index);
      render_synth_frame(scene_, params_, index, frame);
      frame.origin = spec_ + " frame " + std::to_string(index);
      return Status::ok();
    } catch (const std::exception& e) {
      return Status::internal(spec_ + ": rendering failed: " + e.what());
    }
  }

  std::string name() const override { return spec_; }
  std::string calibration_origin() const override { return "the synthetic camera"; }
  std::string colour_origin() const override {
    return colour_ ? "the synthetic colour camera (registered)" : "";
  }
  const Intrinsics& intrinsics() const override { return intrinsics_; }
  double depth_scale() const override { return kSynthDepthScale; }
  std::optional<std::size_t> size() const override {
    return static_cast<std::size_t>(params_.frames);
  }
  const TriangleMesh* scene_mesh() const override { return &mesh_; }
  bool seekable() const override { return true; }
  Status seek(std::size_t index) override {
    if (index >= static_cast<std::size_t>(params_.frames))
      return Status::internal(spec_ + ": cannot seek to frame " + std::to_string(index) + " of " +
                              std::to_string(params_.frames));
    next_ = index;
    return Status::ok();
  }

 private:
  std::string spec_;
  SynthParams params_;
  AnalyticScene scene_;
  Intrinsics intrinsics_;
  TriangleMesh mesh_;
  bool colour_;  ///< the spec asked for colour (colour=on)
  std::uint64_t next_ = 0;
};

}  // namespace

std::unique_ptr<Source> open_synth_source(const std::string& spec) {
  SynthParams params = parse_synth_spec(spec);
  return std::make_unique<SynthSource>(spec, std::move(params));
}

}  // namespace aoscan
