/// @file keyframe_database.cpp
/// @brief Randomised ferns over the encoding image, the keyframe table and its lookup.
#include "fusion/tracking/keyframe_database.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <random>
#include <string>

#include "core/status.h"

namespace aoscan {
namespace {

/// The ferns' seed: fixed, so that a database saved by one run is read by the next.
constexpr std::uint32_t kFernSeed = 0x5eed'f3e5u;
/// Depth thresholds are drawn in this range (m): where a Kinect-class camera measures.
constexpr float kMinThresholdDepth = 0.5f;
constexpr float kMaxThresholdDepth = 4.0f;
/// Normal-component thresholds are drawn in [-kNormalRange, kNormalRange] (z: [-1, 0]: normals
/// face the camera).
constexpr float kNormalRange = 0.7f;
/// The encoding image is smoothed by a Gaussian of this sigma (encoding pixels), over valid
/// pixels only: a frame a few pixels off its keyframe keeps most codes.
constexpr float kBlurSigma = 1.0f;
constexpr int kBlurRadius = 2;
constexpr int kBlurTaps = 2 * kBlurRadius + 1;

/// exp(-(dx^2 + dy^2) / (2 sigma^2)) over the blur window, row by row.
const std::array<float, kBlurTaps * kBlurTaps>& blur_weights() {
  static const std::array<float, kBlurTaps * kBlurTaps> weights = [] {
    std::array<float, kBlurTaps * kBlurTaps> w{};
    for (int dy = -kBlurRadius; dy <= kBlurRadius; ++dy)
      for (int dx = -kBlurRadius; dx <= kBlurRadius; ++dx)
        w[(dy + kBlurRadius) * kBlurTaps + dx + kBlurRadius] =
            std::exp(-static_cast<float>(dx * dx + dy * dy) / (2.0f * kBlurSigma * kBlurSigma));
    return w;
  }();
  return weights;
}

/// Depth and normal of every encoding pixel (depth 0 / zero normal: invalid).
struct EncodingImage {
  std::array<float, kFernImageWidth * kFernImageHeight> depth{};
  std::array<Eigen::Vector3f, kFernImageWidth * kFernImageHeight> normal{};
};

/// Block means of the coarsest level's depth and normals at the encoding resolution.
void reduce(const PointMaps& maps, EncodingImage& out) {
  const int w = maps.vertices.width(), h = maps.vertices.height();
  for (int v = 0; v < kFernImageHeight; ++v) {
    const int y0 = v * h / kFernImageHeight, y1 = std::max(y0 + 1, (v + 1) * h / kFernImageHeight);
    for (int u = 0; u < kFernImageWidth; ++u) {
      const int x0 = u * w / kFernImageWidth, x1 = std::max(x0 + 1, (u + 1) * w / kFernImageWidth);
      float depth_sum = 0.0f;
      int depth_n = 0;
      Eigen::Vector3f normal_sum = Eigen::Vector3f::Zero();
      for (int y = y0; y < std::min(y1, h); ++y)
        for (int x = x0; x < std::min(x1, w); ++x) {
          const float z = maps.vertices(x, y).z();
          if (z > 0.0f) {
            depth_sum += z;
            ++depth_n;
          }
          normal_sum += maps.normals(x, y);
        }
      const int i = v * kFernImageWidth + u;
      out.depth[i] = depth_n > 0 ? depth_sum / static_cast<float>(depth_n) : 0.0f;
      const float norm = normal_sum.norm();
      out.normal[i] = norm > 1e-6f ? Eigen::Vector3f(normal_sum / norm) : Eigen::Vector3f::Zero();
    }
  }
}

/// The Gaussian-weighted mean of the valid values around pixel (x, y) of `in` (depth and normal
/// apart, each over its own valid pixels).
void smooth_at(const EncodingImage& in, int x, int y, float& depth, Eigen::Vector3f& normal) {
  const auto& weights = blur_weights();
  float depth_sum = 0.0f, depth_w = 0.0f;
  Eigen::Vector3f normal_sum = Eigen::Vector3f::Zero();
  for (int dy = -kBlurRadius; dy <= kBlurRadius; ++dy) {
    const int yy = y + dy;
    if (yy < 0 || yy >= kFernImageHeight) continue;
    for (int dx = -kBlurRadius; dx <= kBlurRadius; ++dx) {
      const int xx = x + dx;
      if (xx < 0 || xx >= kFernImageWidth) continue;
      const float w = weights[(dy + kBlurRadius) * kBlurTaps + dx + kBlurRadius];
      const int i = yy * kFernImageWidth + xx;
      if (in.depth[i] > 0.0f) {
        depth_sum += w * in.depth[i];
        depth_w += w;
      }
      normal_sum += w * in.normal[i];
    }
  }
  depth = depth_w > 0.0f ? depth_sum / depth_w : 0.0f;
  const float norm = normal_sum.norm();
  normal = norm > 1e-6f ? Eigen::Vector3f(normal_sum / norm) : Eigen::Vector3f::Zero();
}

}  // namespace

KeyframeDatabase::KeyframeDatabase(const RelocalisationConfig& config) : config_(config) {
  std::mt19937 rng(kFernSeed);
  std::uniform_int_distribution<int> px(0, kFernImageWidth - 1), py(0, kFernImageHeight - 1);
  std::uniform_int_distribution<int> channel(0, 3);
  std::uniform_real_distribution<float> unit(0.0f, 1.0f);
  const int n = std::max(config.ferns, 0) * config.fern_decisions;
  decisions_.resize(static_cast<std::size_t>(n));
  for (Decision& d : decisions_) {
    d.x = px(rng);
    d.y = py(rng);
    d.channel = channel(rng);
    const float t = unit(rng);
    if (d.channel == 0)
      d.threshold = kMinThresholdDepth + t * (kMaxThresholdDepth - kMinThresholdDepth);
    else if (d.channel == 3)
      d.threshold = -t;  // normals face the camera: z in [-1, 0]
    else
      d.threshold = kNormalRange * (2.0f * t - 1.0f);
  }
  table_.resize(static_cast<std::size_t>(std::max(config.ferns, 0)) << config.fern_decisions);
}

FernCodes KeyframeDatabase::encode(const DepthPyramid& frame) const {
  FernCodes codes(static_cast<std::size_t>(std::max(config_.ferns, 0)), 0);
  if (codes.empty()) return codes;
  EncodingImage image;
  reduce(frame.maps[kPyramidLevels - 1], image);
  for (int f = 0; f < config_.ferns; ++f) {
    std::uint8_t code = 0;
    for (int b = 0; b < config_.fern_decisions; ++b) {
      const Decision& d = decisions_[static_cast<std::size_t>(f * config_.fern_decisions + b)];
      float depth;
      Eigen::Vector3f normal;
      smooth_at(image, d.x, d.y, depth, normal);
      bool yes;
      if (d.channel == 0)
        yes = depth > 0.0f && depth > d.threshold;
      else
        yes = normal.squaredNorm() > 0.0f && normal[d.channel - 1] > d.threshold;
      code = static_cast<std::uint8_t>(code | (yes ? 1u << b : 0u));
    }
    codes[static_cast<std::size_t>(f)] = code;
  }
  return codes;
}

void KeyframeDatabase::count_matches(const FernCodes& codes, std::vector<int>& votes) const {
  votes.assign(keyframes_.size(), 0);
  for (std::size_t f = 0; f < codes.size(); ++f)
    for (const int id : table_[(f << config_.fern_decisions) + codes[f]]) ++votes[id];
}

std::vector<KeyframeMatch> KeyframeDatabase::nearest(const FernCodes& codes, int k) const {
  std::vector<KeyframeMatch> matches;
  if (keyframes_.empty() || codes.size() != static_cast<std::size_t>(config_.ferns) || k <= 0)
    return matches;
  std::vector<int> votes;
  count_matches(codes, votes);
  std::vector<int> order(votes.size());
  for (std::size_t i = 0; i < order.size(); ++i) order[i] = static_cast<int>(i);
  const std::size_t take = std::min(order.size(), static_cast<std::size_t>(k));
  std::partial_sort(order.begin(), order.begin() + static_cast<std::ptrdiff_t>(take), order.end(),
                    [&](int a, int b) { return votes[a] != votes[b] ? votes[a] > votes[b] : a < b; });
  for (std::size_t i = 0; i < take; ++i)
    matches.push_back({order[i], 1.0 - static_cast<double>(votes[order[i]]) / config_.ferns});
  return matches;
}

Image<std::uint16_t> depth_to_mm(const Image<float>& depth_m) {
  Image<std::uint16_t> out(depth_m.width(), depth_m.height(), 0);
  for (std::size_t i = 0; i < depth_m.size(); ++i) {
    const float mm = std::round(depth_m.data()[i] * 1000.0f);
    out.data()[i] = mm > 0.0f && mm < 65535.0f ? static_cast<std::uint16_t>(mm) : 0;
  }
  return out;
}

void depth_from_mm(const Image<std::uint16_t>& depth_mm, Image<float>& depth_m) {
  depth_m.resize(depth_mm.width(), depth_mm.height());
  for (std::size_t i = 0; i < depth_mm.size(); ++i)
    depth_m.data()[i] = static_cast<float>(depth_mm.data()[i]) * 0.001f;
}

bool KeyframeDatabase::add_if_novel(const FernCodes& codes, const Pose& T_world_camera,
                                    const DepthPyramid& frame) {
  if (codes.empty() || full()) return false;
  const std::vector<KeyframeMatch> best = nearest(codes, 1);
  if (!best.empty() && best.front().dissimilarity <= config_.keyframe_dissimilarity) return false;
  add({codes, T_world_camera, depth_to_mm(frame.depth_m[kPyramidLevels - 1])});
  return true;
}

void KeyframeDatabase::add(Keyframe keyframe) {
  if (keyframe.codes.size() != static_cast<std::size_t>(config_.ferns))
    throw usage_error("a keyframe has " + std::to_string(keyframe.codes.size()) +
                      " fern codes, the database " + std::to_string(config_.ferns));
  const unsigned limit = 1u << config_.fern_decisions;
  for (const std::uint8_t c : keyframe.codes)
    if (c >= limit)
      throw usage_error("a keyframe's fern code " + std::to_string(c) + " has more than " +
                        std::to_string(config_.fern_decisions) + " bits");
  if (!keyframe.T_world_camera.finite()) throw usage_error("a keyframe's pose is not finite");
  const int id = static_cast<int>(keyframes_.size());
  for (std::size_t f = 0; f < keyframe.codes.size(); ++f)
    table_[(f << config_.fern_decisions) + keyframe.codes[f]].push_back(id);
  keyframes_.push_back(std::move(keyframe));
}

bool KeyframeDatabase::full() const {
  return keyframes_.size() >= static_cast<std::size_t>(config_.max_keyframes);
}

void KeyframeDatabase::clear() {
  keyframes_.clear();
  for (auto& ids : table_) ids.clear();
}

}  // namespace aoscan
