/// @file tum_test.cpp
/// @brief Tests for src/io/tum.h: file lists, trajectories (parse errors, deterministic round
/// trips), nearest-timestamp association.
#include "io/tum.h"

#include <algorithm>
#include <cmath>
#include <functional>

#include <gtest/gtest.h>

#include "core/status.h"
#include "support/error_message.h"
#include "support/scratch_dir.h"

namespace aoscan {
namespace {

/// The message of the bad-input error (exit code 3) that `f` throws.
std::string error_message(const std::function<void()>& f) {
  return testing::error_message(f, ExitCode::kBadInput);
}

using testing::read_bytes;
using testing::ScratchDir;
using testing::write_text;

Pose test_pose(int i) {
  const Eigen::Vector3d axis = Eigen::Vector3d(0.3, -1.0 + 0.1 * i, 0.5).normalized();
  const Eigen::AngleAxisd rotation(0.2 + 0.7 * i, axis);  // beyond pi for large i: qw < 0
  return Pose(rotation.toRotationMatrix(), Eigen::Vector3d(0.1 * i, -2.0 + i / 3.0, 1.0 / (i + 1)));
}

TEST(TumList, CommentsBlankLinesExtraColumnsAndCrlf) {
  ScratchDir dir;
  write_text(dir.file("depth.txt"),
             "# depth maps\n# timestamp filename\n\n"
             "1305031102.160407 depth/1305031102.160407.png\n"
             "   \t\n"
             "1305031102.194330\tdepth/b.png extra columns\r\n"
             "  # indented comment\n"
             "7 c.png");
  const auto entries = read_tum_list(dir.file("depth.txt"));
  ASSERT_EQ(entries.size(), 3u);
  EXPECT_EQ(entries[0].timestamp_s, 1305031102.160407);
  EXPECT_EQ(entries[0].path, "depth/1305031102.160407.png");
  EXPECT_EQ(entries[0].line, 4);
  EXPECT_EQ(entries[1].timestamp_s, 1305031102.194330);
  EXPECT_EQ(entries[1].path, "depth/b.png");
  EXPECT_EQ(entries[1].line, 6);
  EXPECT_EQ(entries[2].timestamp_s, 7.0);
  EXPECT_EQ(entries[2].path, "c.png");
  EXPECT_EQ(entries[2].line, 8);
}

TEST(TumList, GarbledLineNamesFileAndLine) {
  ScratchDir dir;
  const std::string path = dir.file("depth.txt");
  write_text(path, "# header\n0.1 a.png\nnot-a-time b.png\n");
  const std::string m = error_message([&] { read_tum_list(path); });
  EXPECT_NE(m.find(path + ":3:"), std::string::npos) << m;
  write_text(path, "0.1 a.png\n0.2\n");
  const std::string m2 = error_message([&] { read_tum_list(path); });
  EXPECT_NE(m2.find(path + ":2:"), std::string::npos) << m2;
  write_text(path, "nan a.png\n");
  EXPECT_NE(error_message([&] { read_tum_list(path); }).find(path + ":1:"), std::string::npos);
}

TEST(TumList, EmptyListAndMissingFile) {
  ScratchDir dir;
  write_text(dir.file("depth.txt"), "# only a comment\n\n");
  EXPECT_TRUE(read_tum_list(dir.file("depth.txt")).empty());
  const std::string m = error_message([&] { read_tum_list(dir.file("missing.txt")); });
  EXPECT_NE(m.find(dir.file("missing.txt")), std::string::npos) << m;
}

TEST(TumList, WriteReadRoundTrip) {
  ScratchDir dir;
  const std::vector<TumListEntry> entries = {{0.0, "depth/000000.png", 0},
                                             {1305031102.194330, "depth/000001.png", 0}};
  write_tum_list(dir.file("depth.txt"), entries, "recorded by a test\ntimestamp filename");
  EXPECT_EQ(read_bytes(dir.file("depth.txt")),
            "# recorded by a test\n# timestamp filename\n0.000000 depth/000000.png\n"
            "1305031102.194330 depth/000001.png\n");
  const auto back = read_tum_list(dir.file("depth.txt"));
  ASSERT_EQ(back.size(), 2u);
  EXPECT_EQ(back[1].timestamp_s, entries[1].timestamp_s);
  EXPECT_EQ(back[1].path, entries[1].path);
}

TEST(Trajectory, FixedFormat) {
  char line[256];
  StampedPose p{12.5, Pose::identity()};
  ASSERT_GT(format_trajectory_line(line, sizeof line, p), 0);
  EXPECT_STREQ(line,
               "12.500000 0.000000000 0.000000000 0.000000000 0.000000000 0.000000000 0.000000000 "
               "1.000000000\n");
  // A rotation by -90 degrees about z given with qw < 0 comes out with qw > 0; tiny negatives
  // print as positive zero.
  p.T_world_camera =
      Pose::from_quaternion(Eigen::Vector3d(-1e-12, 1.25, -3.0),
                            Eigen::Quaterniond(-std::sqrt(0.5), 0, 0, std::sqrt(0.5)));
  ASSERT_GT(format_trajectory_line(line, sizeof line, p), 0);
  EXPECT_STREQ(line,
               "12.500000 0.000000000 1.250000000 -3.000000000 0.000000000 0.000000000 "
               "-0.707106781 0.707106781\n");
}

TEST(Trajectory, WriteReadRoundTripWithinFormatPrecision) {
  ScratchDir dir;
  std::vector<StampedPose> poses;
  for (int i = 0; i < 12; ++i) poses.push_back({1305031102.160407 + i / 30.0, test_pose(i)});
  write_trajectory(dir.file("a.txt"), poses);
  const auto back = read_trajectory(dir.file("a.txt"));
  ASSERT_EQ(back.size(), poses.size());
  for (std::size_t i = 0; i < poses.size(); ++i) {
    EXPECT_NEAR(back[i].timestamp_s, poses[i].timestamp_s, 5e-7);
    EXPECT_LT((back[i].T_world_camera.translation() - poses[i].T_world_camera.translation())
                  .cwiseAbs()
                  .maxCoeff(),
              5.1e-10);
    // %.9f quaternions: rotation error below 2e-9 per matrix entry.
    EXPECT_LT((back[i].T_world_camera.rotation() - poses[i].T_world_camera.rotation())
                  .cwiseAbs()
                  .maxCoeff(),
              4e-9);
  }
}

TEST(Trajectory, IdenticalInputGivesIdenticalBytes) {
  ScratchDir dir;
  std::vector<StampedPose> poses;
  for (int i = 0; i < 8; ++i) poses.push_back({i * 0.1, test_pose(i)});
  write_trajectory(dir.file("a.txt"), poses);
  {
    TrajectoryWriter writer(dir.file("b.txt"));
    for (const StampedPose& p : poses) writer.write(p);
    writer.close();
  }
  const std::string a = read_bytes(dir.file("a.txt"));
  EXPECT_EQ(a, read_bytes(dir.file("b.txt")));
  EXPECT_EQ(std::count(a.begin(), a.end(), '\n'), 8);
}

TEST(Trajectory, ReadsTumGroundTruthWithHeader) {
  ScratchDir dir;
  write_text(dir.file("groundtruth.txt"),
             "# ground truth trajectory\n# timestamp tx ty tz qx qy qz qw\n"
             "1305031098.6659 1.3563 0.6305 1.6380 0.6132 0.5962 -0.3311 -0.3986\n");
  const auto poses = read_trajectory(dir.file("groundtruth.txt"));
  ASSERT_EQ(poses.size(), 1u);
  EXPECT_EQ(poses[0].timestamp_s, 1305031098.6659);
  EXPECT_EQ(poses[0].T_world_camera.translation(), Eigen::Vector3d(1.3563, 0.6305, 1.6380));
  const Eigen::Quaterniond q(-0.3986, 0.6132, 0.5962, -0.3311);
  EXPECT_LT((poses[0].T_world_camera.rotation() - q.normalized().toRotationMatrix()).norm(), 1e-15);
}

TEST(Trajectory, GarbledLinesNameFileAndLine) {
  ScratchDir dir;
  const std::string path = dir.file("gt.txt");
  for (const char* bad : {"1 2 3 4 5 6 7\n", "1 2 3 4 5 6 7 8 9\n", "1 2 3 x 5 6 7 8\n",
                          "1 2 3 4 0 0 0 0\n", "1 2 3 inf 0 0 0 1\n"}) {
    write_text(path, std::string("# header\n0 0 0 0 0 0 0 1\n") + bad);
    const std::string m = error_message([&] { read_trajectory(path); });
    EXPECT_NE(m.find(path + ":3:"), std::string::npos) << m;
  }
  EXPECT_NE(error_message([&] { read_trajectory(dir.file("none.txt")); }).find("none.txt"),
            std::string::npos);
}

TEST(Associate, NearestWithinTolerance) {
  // Timestamps exact in binary so that the tie case is a real tie.
  std::vector<StampedPose> poses;
  for (int i = 0; i < 5; ++i)
    poses.push_back({1.0 + 0.25 * i, Pose(Eigen::Matrix3d::Identity(), Eigen::Vector3d(i, 0, 0))});
  auto x_of = [&](double t, double max_dt) {
    const auto p = associate(poses, t, max_dt);
    return p ? p->translation().x() : -1.0;
  };
  EXPECT_EQ(x_of(1.0, 0.02), 0.0);
  EXPECT_EQ(x_of(1.51, 0.02), 2.0);
  EXPECT_EQ(x_of(1.74, 0.02), 3.0);
  EXPECT_EQ(x_of(1.625, 0.02), -1.0);  // 125 ms from both neighbours
  EXPECT_EQ(x_of(1.625, 0.125), 2.0);  // equidistant: the earlier pose wins
  EXPECT_EQ(x_of(1.624, 0.2), 2.0);
  EXPECT_EQ(x_of(1.626, 0.2), 3.0);
  EXPECT_EQ(x_of(0.99, 0.02), 0.0);  // before the first pose
  EXPECT_EQ(x_of(2.01, 0.02), 4.0);  // after the last pose
  EXPECT_EQ(x_of(2.1, 0.02), -1.0);
  EXPECT_FALSE(associate({}, 1.0, 1.0).has_value());
}

}  // namespace
}  // namespace aoscan

namespace aoscan {
namespace {

std::vector<TumListEntry> stamps(const std::vector<double>& t) {
  std::vector<TumListEntry> list;
  for (double s : t) list.push_back({s, "f" + std::to_string(list.size())});
  return list;
}

TEST(AssociateLists, ClosestPairsFirstEachEntryOnce) {
  // Depth at 0, 0.033, 0.066, 0.2; colour at 0.005, 0.030, 0.031, 0.5, 0.07 (not sorted). Pairs
  // by |dt|: (depth 1, colour 2) 0.002 first, so depth 1 does not take colour 1 (0.003), which no
  // other depth frame is near; (2, 4) 0.004; (0, 0) 0.005. Depth 3 has none within 0.02.
  const auto depth = stamps({0.0, 0.033, 0.066, 0.2});
  const auto colour = stamps({0.005, 0.030, 0.031, 0.5, 0.07});
  const auto partner = associate_lists(depth, colour, 0.02);
  ASSERT_EQ(partner.size(), 4u);
  EXPECT_EQ(partner[0], std::optional<std::size_t>(0));
  EXPECT_EQ(partner[1], std::optional<std::size_t>(2));
  EXPECT_EQ(partner[2], std::optional<std::size_t>(4));
  EXPECT_FALSE(partner[3].has_value());
}

TEST(AssociateLists, OneColourFrameServesOneDepthFrame) {
  // Two depth frames equally near one colour frame: the earlier depth frame takes it.
  const auto partner = associate_lists(stamps({1.0, 1.02}), stamps({1.01}), 0.02);
  EXPECT_EQ(partner[0], std::optional<std::size_t>(0));
  EXPECT_FALSE(partner[1].has_value());
  // Just within max_dt pairs, just beyond does not; nothing pairs with an empty list.
  EXPECT_EQ(associate_lists(stamps({2.0}), stamps({2.0195}), 0.02)[0],
            std::optional<std::size_t>(0));
  EXPECT_FALSE(associate_lists(stamps({2.0}), stamps({2.0205}), 0.02)[0].has_value());
  EXPECT_FALSE(associate_lists(stamps({2.0}), {}, 0.02)[0].has_value());
  EXPECT_TRUE(associate_lists({}, stamps({2.0}), 0.02).empty());
}

}  // namespace
}  // namespace aoscan
