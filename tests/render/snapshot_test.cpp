/// @file snapshot_test.cpp
/// @brief Headless snapshots: which frames, which files, their content, errors; embedded shaders;
/// the CLI options.
#include "render/snapshot.h"

#include <png.h>
#include <sys/wait.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <string>

#include <gtest/gtest.h>

#include "io/png_read.h"
#include "io/snapshot_files.h"
#include "render/gl_renderer.h"
#include "render/render_test_util.h"
#include "render/shaders.h"
#include "support/scratch_dir.h"

namespace aoscan {
namespace {

namespace fs = std::filesystem;

TEST(Snapshot, WritesEveryNthFrameEveryView) {
  testing::ScratchDir dir;
  SnapshotOptions options;
  options.dir = dir.file("snaps/nested");
  options.every_n = 3;
  SnapshotWriter writer(options);
  ViewFrame frame = testing::sphere_wall_frame(32, 24);
  frame.surface = testing::sphere_points({0, 0, 2}, 0.5f, 10);
  for (std::uint64_t s = 10; s < 17; ++s) {
    frame.sequence = s;
    ASSERT_TRUE(writer.offer(frame).is_ok());
  }
  // Offers 0, 3, 6 → sequences 10, 13, 16: every view and the raycast's depth.
  EXPECT_EQ(writer.files_written(), 3u * (kViewCount + 1));
  for (std::uint64_t s : {10u, 13u, 16u}) {
    for (int v = 0; v < kViewCount; ++v)
      EXPECT_TRUE(fs::exists(writer.path(static_cast<View>(v), s))) << s;
    EXPECT_TRUE(fs::exists(writer.path(kRaycastDepthView, s))) << s;
  }
  EXPECT_FALSE(fs::exists(writer.path(View::kShaded, 11)));
  EXPECT_EQ(fs::path(writer.path(View::kNormals, 13)).filename(), "normals_000013.png");

  // The file holds exactly the composite.
  png_image image{};
  image.version = PNG_IMAGE_VERSION;
  ASSERT_TRUE(png_image_begin_read_from_file(&image, writer.path(View::kShaded, 13).c_str()));
  image.format = PNG_FORMAT_RGB;
  Image<Rgb8> back(static_cast<int>(image.width), static_cast<int>(image.height));
  ASSERT_TRUE(png_image_finish_read(&image, nullptr, back.data(), 0, nullptr));
  Image<Rgb8> expected;
  composite_view(frame, View::kShaded, expected);
  EXPECT_EQ(back, expected);

  // The raycast's depth: 16-bit, 5000 units a metre, rounded; 0 where there is no surface.
  Image<std::uint16_t> depth;
  ASSERT_TRUE(read_grey16_png(writer.path(kRaycastDepthView, 13), depth).is_ok());
  ASSERT_EQ(depth.width(), frame.depth_m.width());
  ASSERT_EQ(depth.height(), frame.depth_m.height());
  int surface = 0;
  for (int y = 0; y < depth.height(); ++y)
    for (int x = 0; x < depth.width(); ++x) {
      const float d = frame.depth_m(x, y);
      const int want = d > 0.0f ? static_cast<int>(std::lround(d * 5000.0)) : 0;
      EXPECT_EQ(depth(x, y), want) << x << "," << y;
      surface += want > 0;
    }
  EXPECT_GT(surface, 0);
}

TEST(Snapshot, ErrorsAreOneLineNamingThePath) {
  testing::ScratchDir dir;
  testing::write_text(dir.file("file"), "x");
  SnapshotOptions options;
  options.dir = dir.file("file/sub");  // a folder inside a file
  try {
    SnapshotWriter writer(options);
    FAIL() << "no exception";
  } catch (const Error& e) {
    EXPECT_EQ(e.code(), ExitCode::kUsage);
    EXPECT_NE(std::string(e.what()).find(options.dir), std::string::npos);
  }
  options.dir = dir.str();
  options.every_n = 0;
  EXPECT_THROW(SnapshotWriter{options}, Error);

  options.every_n = 1;
  SnapshotWriter writer(options);
  fs::remove_all(dir.str());  // the folder vanished mid-run
  const Status s = writer.write(testing::sphere_wall_frame(8, 6));
  EXPECT_EQ(s.code(), Status::Code::kInternal);
  EXPECT_NE(s.message().find("shaded_000007.png"), std::string::npos) << s.message();
}

TEST(EmbeddedShaders, EveryProgramsFilesAreEmbeddedAndUsed) {
  for (const ProgramSpec& spec : program_specs()) {
    EXPECT_NE(find_shader(spec.vertex), nullptr) << spec.vertex;
    EXPECT_NE(find_shader(spec.fragment), nullptr) << spec.fragment;
  }
  ASSERT_FALSE(embedded_shaders().empty());
  for (const ShaderFile& file : embedded_shaders()) {
    EXPECT_EQ(std::string(file.text).rfind("#version 330 core", 0), 0u) << file.name;
    bool used = false;
    for (const ProgramSpec& spec : program_specs())
      used =
          used || file.name == std::string(spec.vertex) || file.name == std::string(spec.fragment);
    EXPECT_TRUE(used) << file.name << " is embedded but no program uses it";
  }
  // The same text as the file in the source tree (the build embeds the current version).
  const std::string on_disk =
      testing::read_bytes(std::string(AOSCAN_SOURCE_DIR) + "/shaders/shaded.frag");
  EXPECT_EQ(on_disk, find_shader("shaded.frag"));
}

TEST(SnapshotCli, RunCommandsOfferSnapshotOptions) {
  testing::ScratchDir dir;
  for (const char* cmd : {"replay", "scan"}) {
    const std::string out = dir.file(std::string(cmd) + ".txt");
    const std::string line = std::string(AOSCAN_BINARY) + " " + cmd + " --help > " + out;
    ASSERT_EQ(std::system(line.c_str()), 0) << line;
    const std::string help = testing::read_bytes(out);
    EXPECT_NE(help.find("--snapshot "), std::string::npos) << help;
    EXPECT_NE(help.find("--snapshot-every"), std::string::npos) << help;
  }
  // --snapshot-every needs --snapshot and a positive count (usage errors, exit 2).
  const std::string err = dir.file("err.txt");
  const std::string base = std::string(AOSCAN_BINARY) + " replay synth:corner --headless ";
  EXPECT_EQ(WEXITSTATUS(std::system((base + "--snapshot-every 2 2> " + err).c_str())), 2);
  EXPECT_EQ(WEXITSTATUS(std::system(
                (base + "--snapshot " + dir.file("s") + " --snapshot-every 0 2> " + err).c_str())),
            2);
}

}  // namespace
}  // namespace aoscan
