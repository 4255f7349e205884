/// @file recorder_test.cpp
/// @brief Tests for src/capture/recorder.h: a known in-test Source recorded and read back with
/// open_tum_folder, refusal of an existing recording, limits, and streams that end in an error.
#include "capture/recorder.h"

#include <algorithm>
#include <filesystem>
#include <set>

#include <gtest/gtest.h>

#include "capture/output_file.h"
#include "capture/source.h"
#include "capture/tum_source.h"
#include "io/ply.h"
#include "io/tum.h"
#include "support/scratch_dir.h"

namespace aoscan {
namespace {

using testing::read_bytes;
using testing::ScratchDir;
using testing::write_text;

const Intrinsics kIntrinsics{20, 10, 585.5, 584.25, 9.75, 4.5};
constexpr double kDepthScale = 1000.0;

Image<std::uint16_t> frame_image(int i) {
  Image<std::uint16_t> image(kIntrinsics.width, kIntrinsics.height);
  for (int y = 0; y < image.height(); ++y)
    for (int x = 0; x < image.width(); ++x)
      image(x, y) = static_cast<std::uint16_t>((x + y) % 7 == 0 ? 0 : 800 + 100 * i + 3 * x + y);
  return image;
}

Pose frame_pose(int i) {
  const Eigen::AngleAxisd r(0.1 * i, Eigen::Vector3d(0.2, 1.0, -0.3).normalized());
  return Pose(r.toRotationMatrix(), Eigen::Vector3d(0.01 * i, -0.5, 1.0 + 0.02 * i));
}

double frame_time(int i) {
  return 100.0 + i / 30.0;
}

/// `frames` frames (sequence i, frame_image(i), frame_pose(i)) with corrupt_frame at `corrupt`,
/// then `last` forever; a two-triangle scene mesh.
class FakeSource : public Source {
 public:
  FakeSource(int frames, std::set<int> corrupt, Status last, bool with_gt = true,
             bool with_mesh = true)
      : frames_(frames), corrupt_(std::move(corrupt)), last_(std::move(last)), with_gt_(with_gt) {
    if (with_mesh) {
      mesh_.vertices = {{0, 0, 1}, {1, 0, 1}, {0, 1, 1}, {1, 1, 2}};
      mesh_.faces = {{0, 1, 2}, {1, 3, 2}};
    }
  }
  Status read(DepthFrame& frame) override {
    if (next_ >= frames_) return last_;
    const int i = next_++;
    if (corrupt_.count(i)) return Status::corrupt_frame("fake (frame " + std::to_string(i) + ")");
    frame.depth = frame_image(i);
    frame.depth_scale = kDepthScale;
    frame.intrinsics = kIntrinsics;
    frame.timestamp_s = frame_time(i);
    frame.sequence = static_cast<std::uint64_t>(i);
    frame.origin = "fake";
    frame.T_world_camera_gt = with_gt_ ? std::optional<Pose>(frame_pose(i)) : std::nullopt;
    return Status::ok();
  }
  std::string name() const override { return "fake:test"; }
  const Intrinsics& intrinsics() const override { return kIntrinsics; }
  double depth_scale() const override { return kDepthScale; }
  std::optional<std::size_t> size() const override { return frames_; }
  const TriangleMesh* scene_mesh() const override { return mesh_.empty() ? nullptr : &mesh_; }

 private:
  int frames_;
  std::set<int> corrupt_;
  Status last_;
  bool with_gt_;
  int next_ = 0;
  TriangleMesh mesh_;
};

/// Reads the recording back and checks each frame against the fake's frame `expected[k]`.
void expect_recording(const std::string& dir, const std::vector<int>& expected, bool with_gt) {
  const auto source = open_tum_folder(dir);
  EXPECT_EQ(source->intrinsics(), kIntrinsics);
  EXPECT_EQ(source->depth_scale(), kDepthScale);
  ASSERT_EQ(source->size(), std::optional<std::size_t>(expected.size()));
  DepthFrame frame;
  for (std::size_t k = 0; k < expected.size(); ++k) {
    const int i = expected[k];
    const Status s = source->read(frame);
    ASSERT_TRUE(s.is_ok()) << s.message();
    EXPECT_EQ(frame.depth, frame_image(i));
    EXPECT_EQ(frame.intrinsics, kIntrinsics);
    EXPECT_EQ(frame.depth_scale, kDepthScale);
    EXPECT_NEAR(frame.timestamp_s, frame_time(i), 5e-7);
    char name[32];
    std::snprintf(name, sizeof name, "/depth/%06d.png", i);
    EXPECT_EQ(frame.origin, dir + name);
    ASSERT_EQ(frame.T_world_camera_gt.has_value(), with_gt);
    if (with_gt) {
      EXPECT_LT((frame.T_world_camera_gt->translation() - frame_pose(i).translation()).norm(),
                1e-9);
      EXPECT_LT((frame.T_world_camera_gt->rotation() - frame_pose(i).rotation()).norm(), 1e-8);
    }
  }
  EXPECT_EQ(source->read(frame).code(), Status::Code::kEndOfStream);
}

TEST(Recorder, RecordedFramesReadBackIdentical) {
  ScratchDir scratch;
  const std::string dir = scratch.file("made/by/record");  // parents are created
  FakeSource source(6, {2}, Status::end_of_stream());
  const RecordStats stats = record_source(source, dir, std::nullopt, nullptr);
  EXPECT_EQ(stats.frames_written, 5u);
  EXPECT_EQ(stats.frames_corrupt, 1u);
  expect_recording(dir, {0, 1, 3, 4, 5}, true);

  const std::string list = read_bytes(dir + "/depth.txt");
  EXPECT_EQ(list.rfind("# ", 0), 0u);
  EXPECT_NE(list.find("100.100000 depth/000003.png\n"), std::string::npos) << list;
  EXPECT_FALSE(std::filesystem::exists(dir + "/depth/000002.png"));
  EXPECT_EQ(read_trajectory(dir + "/groundtruth.txt").size(), 5u);
  const TriangleMesh scene = read_ply(dir + "/scene.ply");
  EXPECT_EQ(scene.vertices, source.scene_mesh()->vertices);
  EXPECT_EQ(scene.faces, source.scene_mesh()->faces);
}

TEST(Recorder, ColourIsRecordedAndReadsBackIdentical) {
  ScratchDir scratch;
  const std::string dir = scratch.file("colour");
  const std::string spec = "synth:corner?frames=3&width=32&height=24&colour=on";
  const std::unique_ptr<Source> source = open_source(spec);
  EXPECT_EQ(record_source(*source, dir, std::nullopt, nullptr).frames_written, 3u);
  const std::string list = read_bytes(dir + "/rgb.txt");
  EXPECT_NE(list.find("0.033333 rgb/000001.png\n"), std::string::npos) << list;
  // The recording's frames carry the same colour and a registered colour camera.
  const std::unique_ptr<Source> again = open_source(spec);
  const auto recording = open_tum_folder(dir);
  EXPECT_EQ(recording->colour_origin(), dir + "/camera.json");
  DepthFrame original, read;
  for (int i = 0; i < 3; ++i) {
    ASSERT_TRUE(again->read(original).is_ok());
    ASSERT_TRUE(recording->read(read).is_ok());
    ASSERT_TRUE(read.colour_camera.has_value());
    EXPECT_TRUE(read.colour_camera->registered);
    EXPECT_EQ(read.colour_error, "");
    ASSERT_EQ(read.colour.width(), 32);
    for (std::size_t p = 0; p < read.colour.size(); ++p)
      ASSERT_EQ(read.colour.data()[p], original.colour.data()[p]) << "frame " << i;
  }
  // A source without colour records none.
  const std::unique_ptr<Source> plain = open_source("synth:corner?frames=1&width=32&height=24");
  record_source(*plain, scratch.file("plain"), std::nullopt, nullptr);
  EXPECT_FALSE(std::filesystem::exists(scratch.file("plain") + "/rgb.txt"));
}

TEST(Recorder, IdenticalRunsGiveIdenticalFiles) {
  ScratchDir scratch;
  FakeSource a(3, {}, Status::end_of_stream()), b(3, {}, Status::end_of_stream());
  record_source(a, scratch.file("a"), std::nullopt, nullptr);
  record_source(b, scratch.file("b"), std::nullopt, nullptr);
  for (const char* file : {"depth.txt", "camera.json", "groundtruth.txt", "scene.ply",
                           "depth/000000.png", "depth/000002.png"})
    EXPECT_EQ(read_bytes(scratch.file(std::string("a/") + file)),
              read_bytes(scratch.file(std::string("b/") + file)))
        << file;
}

TEST(Recorder, RefusesAnExistingRecording) {
  ScratchDir scratch;
  FakeSource first(2, {}, Status::end_of_stream());
  record_source(first, scratch.str(), std::nullopt, nullptr);
  const std::string before = read_bytes(scratch.file("depth.txt"));
  FakeSource second(3, {}, Status::end_of_stream());
  try {
    record_source(second, scratch.str(), std::nullopt, nullptr);
    ADD_FAILURE() << "no error";
  } catch (const Error& e) {
    EXPECT_EQ(e.code(), ExitCode::kUsage);
    EXPECT_NE(std::string(e.what()).find(scratch.str()), std::string::npos) << e.what();
  }
  EXPECT_EQ(read_bytes(scratch.file("depth.txt")), before);
}

TEST(Recorder, MaxFramesAndStopRequest) {
  ScratchDir scratch;
  FakeSource source(6, {0}, Status::end_of_stream());
  const RecordStats stats = record_source(source, scratch.file("two"), 2, nullptr);
  EXPECT_EQ(stats.frames_written, 2u);
  EXPECT_EQ(stats.frames_corrupt, 1u);
  expect_recording(scratch.file("two"), {1, 2}, true);

  const std::atomic<bool> stop{true};
  FakeSource stopped(6, {}, Status::end_of_stream());
  EXPECT_EQ(record_source(stopped, scratch.file("none"), std::nullopt, &stop).frames_written, 0u);
  // Nothing recorded, yet the folder says what it is.
  EXPECT_TRUE(std::filesystem::exists(scratch.file("none/camera.json")));
  EXPECT_EQ(read_tum_list(scratch.file("none/depth.txt")).size(), 0u);
}

TEST(Recorder, WithoutGroundTruthOrMesh) {
  ScratchDir scratch;
  FakeSource source(2, {}, Status::end_of_stream(), false, false);
  record_source(source, scratch.str(), std::nullopt, nullptr);
  EXPECT_FALSE(std::filesystem::exists(scratch.file("groundtruth.txt")));
  EXPECT_FALSE(std::filesystem::exists(scratch.file("scene.ply")));
  expect_recording(scratch.str(), {0, 1}, false);
}

TEST(Recorder, StreamErrorsEndTheRecordingWithAValidFolder) {
  ScratchDir scratch;
  FakeSource bad(3, {1}, Status::bad_input("fake: file vanished"));
  const RecordStats b = record_source(bad, scratch.file("bad"), std::nullopt, nullptr);
  EXPECT_EQ(b.stopped_by.code(), Status::Code::kBadInput);
  EXPECT_EQ(b.stopped_by.message(), "fake: file vanished");
  EXPECT_EQ(b.frames_written, 2u);
  EXPECT_EQ(b.frames_corrupt, 1u);
  expect_recording(scratch.file("bad"), {0, 2}, true);
  EXPECT_EQ(read_trajectory(scratch.file("bad/groundtruth.txt")).size(), 2u);

  FakeSource lost(2, {}, Status::device_lost("fake: unplugged"));
  const RecordStats l = record_source(lost, scratch.file("lost"), std::nullopt, nullptr);
  EXPECT_EQ(l.stopped_by.code(), Status::Code::kDeviceLost);
  EXPECT_EQ(l.frames_written, 2u);
  try {
    throw_for_status(l.stopped_by);
  } catch (const Error& e) {
    EXPECT_EQ(e.code(), ExitCode::kDevice);
  }
  expect_recording(scratch.file("lost"), {0, 1}, true);

  FakeSource none(0, {}, Status::device_lost("fake: unplugged at once"));
  const RecordStats n = record_source(none, scratch.file("none"), std::nullopt, nullptr);
  EXPECT_EQ(n.frames_written, 0u);
  EXPECT_EQ(n.stopped_by.code(), Status::Code::kDeviceLost);
}

/// `text` without its `#` comment lines.
std::string data_lines(const std::string& text) {
  std::string out;
  std::size_t start = 0;
  while (start < text.size()) {
    const std::size_t end = std::min(text.find('\n', start), text.size() - 1) + 1;
    if (text[start] != '#') out += text.substr(start, end - start);
    start = end;
  }
  return out;
}

TEST(Recorder, ReRecordingARecordingIsLossless) {
  ScratchDir scratch;
  FakeSource source(4, {}, Status::end_of_stream());
  record_source(source, scratch.file("one"), std::nullopt, nullptr);
  const auto reopened = open_tum_folder(scratch.file("one"));
  record_source(*reopened, scratch.file("two"), std::nullopt, nullptr);
  auto bytes = [&](const std::string& file) { return read_bytes(scratch.file(file)); };
  for (const std::string file : {"camera.json", "depth/000000.png", "depth/000003.png"}) {
    EXPECT_FALSE(bytes("one/" + file).empty()) << file;
    EXPECT_EQ(bytes("one/" + file), bytes("two/" + file)) << file;
  }
  // The lists are identical but for their header comments, which name the source.
  for (const std::string file : {"depth.txt", "groundtruth.txt"}) {
    const std::string one = bytes("one/" + file);
    EXPECT_EQ(std::count(one.begin(), one.end(), '\n'), 6) << file;  // 2 comments + 4 frames
    EXPECT_EQ(data_lines(one), data_lines(bytes("two/" + file))) << file;
  }
}

}  // namespace
}  // namespace aoscan
