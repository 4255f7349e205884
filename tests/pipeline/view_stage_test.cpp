// Tests for src/pipeline/view_stage.cpp, view_products.cpp and the session's view wiring:
// snapshots of a short replay, a slow window never blocks the chain, the user's commands.
#include "pipeline/view_stage.h"

#include <png.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <functional>
#include <mutex>
#include <set>
#include <thread>

#include <gtest/gtest.h>
#include <Eigen/Geometry>

#include "capture/source.h"
#include "fake_source.h"
#include "io/tum.h"
#include "pipeline/session.h"
#include "pipeline/view_products.h"
#include "support/pipeline_reference.h"
#include "support/scratch_dir.h"

namespace aoscan {
namespace {

namespace fs = std::filesystem;
using namespace std::chrono_literals;

/// Width and height of a PNG (0, 0 when unreadable).
std::pair<int, int> png_size(const fs::path& path) {
  png_image image{};
  image.version = PNG_IMAGE_VERSION;
  if (!png_image_begin_read_from_file(&image, path.c_str())) return {0, 0};
  png_image_free(&image);
  return {static_cast<int>(image.width), static_cast<int>(image.height)};
}

/// Fraction of the pixels of a PNG that differ from its top-left pixel (-1 when unreadable).
double fraction_unlike_corner(const fs::path& path) {
  png_image image{};
  image.version = PNG_IMAGE_VERSION;
  if (!png_image_begin_read_from_file(&image, path.c_str())) return -1.0;
  image.format = PNG_FORMAT_RGB;
  std::vector<unsigned char> rgb(PNG_IMAGE_SIZE(image));
  if (!png_image_finish_read(&image, nullptr, rgb.data(), 0, nullptr)) return -1.0;
  std::size_t unlike = 0;
  const std::size_t pixels = rgb.size() / 3;
  for (std::size_t i = 1; i < pixels; ++i)
    unlike += (rgb[3 * i] != rgb[0] || rgb[3 * i + 1] != rgb[1] || rgb[3 * i + 2] != rgb[2]);
  return static_cast<double>(unlike) / static_cast<double>(pixels);
}

/// A view stage of a one-stage chain that publishes for a window.
ViewStageOptions window_options() {
  ViewStageOptions options;
  options.stage_names = {"capture", "view"};
  options.publish = true;
  return options;
}

/// Camera-frame maps of a fronto-parallel wall at `depth_m` (every pixel valid).
PointMaps wall_maps(int width, int height, float depth_m) {
  PointMaps maps;
  maps.intrinsics.width = width;
  maps.intrinsics.height = height;
  maps.intrinsics.fx = maps.intrinsics.fy = width;
  maps.intrinsics.cx = 0.5 * width;
  maps.intrinsics.cy = 0.5 * height;
  maps.vertices.resize(width, height, Eigen::Vector3f(Eigen::Vector3f::Zero()));
  maps.normals.resize(width, height, Eigen::Vector3f(0, 0, -1));
  for (int y = 0; y < height; ++y)
    for (int x = 0; x < width; ++x)
      maps.vertices(x, y) =
          maps.intrinsics.unproject(static_cast<float>(x), static_cast<float>(y), depth_m);
  return maps;
}

/// Every pixel of `a` is `b`'s, bit for bit, or NaN where `b` is.
void expect_same_pixels(const Image<float>& a, const Image<float>& b) {
  ASSERT_EQ(a.width(), b.width());
  ASSERT_EQ(a.height(), b.height());
  for (int y = 0; y < a.height(); ++y)
    for (int x = 0; x < a.width(); ++x) {
      const float f = a(x, y), r = b(x, y);
      EXPECT_TRUE((std::isnan(f) && std::isnan(r)) || f == r) << x << "," << y;
    }
}

/// 100 x 48 pixels of a wall at 1 m (100 a row: the batched lookup's batches do not divide a
/// row), seen from a rotated pose, with its AO image (ao_of_x) and weights 1.
struct WallView {
  static constexpr int kWidth = 100, kHeight = 48;
  PointMaps maps = wall_maps(kWidth, kHeight, 1.0f);
  Image<float> ao{kWidth, kHeight}, weight{kWidth, kHeight, 1.0f};
  Pose T_world_camera{
      Eigen::AngleAxisd(0.3, Eigen::Vector3d(1, 2, 3).normalized()).toRotationMatrix(),
      Eigen::Vector3d(-0.7, 0.2, 1.3)};
  explicit WallView(float (*ao_of_x)(int x)) {
    for (int y = 0; y < kHeight; ++y)
      for (int x = 0; x < kWidth; ++x) ao(x, y) = ao_of_x(x);
  }
};

TEST(MvaoImage, ParallelEqualsReferenceAndReadsTheObservedCells) {
  AoConfig config;
  MvaoGrid grid(config);
  WallView wall([](int x) { return x < WallView::kWidth / 2 ? 0.25f : 0.75f; });
  const int width = WallView::kWidth, height = WallView::kHeight;
  const PointMaps& maps = wall.maps;
  const Pose& T_world_camera = wall.T_world_camera;
  for (int y = 24; y < height; ++y)
    for (int x = 0; x < width; ++x) wall.weight(x, y) = 0.0f;  // lower half never observed
  Image<std::uint32_t> slots;
  ASSERT_TRUE(grid.integrate(wall.ao, wall.weight, maps, T_world_camera, &slots).is_ok());

  PointMaps seen = maps;
  seen.vertices(5, 5).setZero();  // no surface
  seen.vertices(6, 5).setConstant(std::numeric_limits<float>::quiet_NaN());
  seen.vertices(7, 5) = Eigen::Vector3f(0.0f, 0.0f, 1e9f);  // outside the Morton range
  Image<float> fast, from_slots, reference;
  mvao_image(grid, seen, T_world_camera, fast);
  test::mvao_image_reference(grid, seen, T_world_camera, reference);
  // The slots of the frame just integrated (upper half; the lower half had no weight and is
  // looked up): the same image for the maps that frame integrated.
  mvao_image(grid, maps, T_world_camera, from_slots, &slots);
  Image<float> reference_unchanged;
  test::mvao_image_reference(grid, maps, T_world_camera, reference_unchanged);
  expect_same_pixels(from_slots, reference_unchanged);
  int from_slot = 0;
  for (int y = 0; y < height; ++y)
    for (int x = 0; x < width; ++x) from_slot += slots(x, y) != MvaoGrid::kNoSlot ? 1 : 0;
  EXPECT_EQ(from_slot, width * 24);
  expect_same_pixels(fast, reference);
  for (int x = 5; x <= 7; ++x) EXPECT_TRUE(std::isnan(fast(x, 5))) << x;
  EXPECT_FLOAT_EQ(fast(2, 10), 0.25f);    // a cell only the left half touched
  EXPECT_FLOAT_EQ(fast(96, 10), 0.75f);   // only the right half
  EXPECT_TRUE(std::isnan(fast(10, 46)));  // unobserved cell
}

TEST(MvaoImage, CoarseReadEqualsTheCoarsenedGridSampledPixelByPixel) {
  // Two frames of a wall under two poses, AO varying along x: the coarse image (brick sums
  // refreshed by the call, rows in parallel) is the serial reference's bit for bit, also after a
  // third frame changed some bricks; ao.view_read cells gives the per-cell image.
  AoConfig config;
  MvaoGrid grid(config);
  WallView wall([](int x) { return 0.2f + 0.6f * static_cast<float>(x) / WallView::kWidth; });
  const Pose& first = wall.T_world_camera;
  const Pose second(
      Eigen::AngleAxisd(0.1, Eigen::Vector3d(0, 1, 0)).toRotationMatrix() * first.rotation(),
      first.translation() + Eigen::Vector3d(0.05, 0.0, 0.02));
  ASSERT_TRUE(grid.integrate(wall.ao, wall.weight, wall.maps, first).is_ok());
  ASSERT_TRUE(grid.integrate(wall.ao, wall.weight, wall.maps, second).is_ok());
  PointMaps seen = wall.maps;
  seen.vertices(5, 5).setZero();  // no surface
  for (int round = 0; round < 2; ++round) {
    Image<float> coarse, reference;
    mvao_image(grid, AoViewRead::kCoarse, seen, second, coarse);
    EXPECT_EQ(grid.stale_bricks(), 0u);
    test::mvao_image_coarse_reference(grid, seen, second, reference);
    expect_same_pixels(coarse, reference);
    int shown = 0;
    for (std::size_t i = 0; i < coarse.size(); ++i) shown += std::isnan(coarse.data()[i]) ? 0 : 1;
    EXPECT_EQ(shown, WallView::kWidth * WallView::kHeight - 1);
    EXPECT_TRUE(std::isnan(coarse(5, 5)));
    // A third view brightens the left half.
    for (int y = 0; y < WallView::kHeight; ++y)
      for (int x = 0; x < WallView::kWidth / 2; ++x) wall.ao(x, y) = 1.0f;
    ASSERT_TRUE(grid.integrate(wall.ao, wall.weight, wall.maps, first).is_ok());
    EXPECT_GT(grid.stale_bricks(), 0u);
  }
  Image<float> cells, cells_reference;
  mvao_image(grid, AoViewRead::kCells, seen, second, cells);
  test::mvao_image_reference(grid, seen, second, cells_reference);
  expect_same_pixels(cells, cells_reference);
}

TEST(SurfaceCloud, OnePointPerVoxelWithTheNewestObservedAo) {
  SurfaceCloudOptions options;
  options.voxel_m = 0.05;
  options.pixel_step = 1;
  SurfaceCloud cloud(options);
  // A wall at 1 m seen by 40x40 pixels of focal length 40: 1 m x 1 m → 20 x 20 voxels of 5 cm.
  PointMaps maps = wall_maps(40, 40, 1.0f);
  Image<float> ao(40, 40, 0.5f);
  cloud.add(maps, ao, Pose());
  const std::size_t points = cloud.size();
  EXPECT_GE(points, 400u);
  EXPECT_LE(points, 21u * 21u);
  ao.resize(40, 40, std::numeric_limits<float>::quiet_NaN());
  cloud.add(maps, ao, Pose());  // NaN AO keeps the observed value
  ao.resize(40, 40, 0.9f);
  ao(0, 0) = 0.9f;
  std::shared_ptr<const TriangleMesh> before = cloud.to_mesh();
  cloud.add(maps, ao, Pose());
  EXPECT_EQ(cloud.size(), points);  // same voxels: no new point
  const std::shared_ptr<const TriangleMesh> mesh = cloud.to_mesh();
  ASSERT_EQ(mesh->quality.size(), points);
  EXPECT_TRUE(mesh->faces.empty());
  for (std::size_t i = 0; i < points; ++i) {
    EXPECT_FLOAT_EQ(before->quality[i], 0.5f);
    EXPECT_FLOAT_EQ(mesh->quality[i], 0.9f);
    EXPECT_NEAR(mesh->vertices[i].z(), 1.0f, 1e-6);
  }
  cloud.clear();
  EXPECT_EQ(cloud.size(), 0u);

  SurfaceCloudOptions small = options;
  small.max_points = 10;
  SurfaceCloud bounded(small);
  bounded.add(maps, ao, Pose());
  EXPECT_EQ(bounded.size(), 10u);
  EXPECT_GT(bounded.points_refused(), 0u);
}

TEST(ViewStage, SnapshotsOfAShortReplayHaveTheExpectedNamesAndSizes) {
  aoscan::testing::ScratchDir scratch;
  const fs::path out = scratch.path("snap_out");
  const fs::path snaps = scratch.path("snap_png");
  std::unique_ptr<Source> source = open_source("synth:corner?frames=8&width=160&height=120");
  RunOptions options;
  options.out_dir = out.string();
  options.threads = 2;
  options.snapshot_dir = snaps.string();
  options.snapshot_every = 4;
  std::atomic<bool> stop{false};
  const SessionResult r = run_session(*source, options, stop);
  ASSERT_EQ(r.exit_code, ExitCode::kOk) << r.error;
  EXPECT_EQ(r.pipeline.counters.frames_processed, 8u);
  // Frames 0 and 4 by --snapshot-every, frame 7 as the last set: 3 x 9 views.
  std::set<std::string> names;
  for (const auto& e : fs::directory_iterator(snaps)) names.insert(e.path().filename().string());
  std::set<std::string> expected;
  for (const char* view :
       {"shaded", "ssao", "mvao", "colour", "colour_mvao", "normals", "depth", "orbit", "splats",
        "raycast_depth"})
    for (const char* seq : {"000000", "000004", "000007"})
      expected.insert(std::string(view) + "_" + seq + ".png");
  EXPECT_EQ(names, expected);
  EXPECT_EQ(r.session.snapshot_files, 30u);
  for (const std::string& name : expected) {
    const auto [w, h] = png_size(snaps / name);
    EXPECT_EQ(w, 160) << name;
    EXPECT_EQ(h, 120) << name;
  }
  for (const char* f : {"mesh.ply", "trajectory.txt", "stats.json"})
    EXPECT_TRUE(fs::exists(out / f)) << f;
}

TEST(ViewStage, FullResolutionSnapshotsShowTheHalfResolutionModel) {
  aoscan::testing::ScratchDir scratch;
  // At 640x480 the model is raycast at 320x240: its views are enlarged, not left empty.
  const fs::path out = scratch.path("snap_full_out");
  const fs::path snaps = scratch.path("snap_full_png");
  std::unique_ptr<Source> source = open_source("synth:corner?frames=2");
  RunOptions options;
  options.out_dir = out.string();
  options.threads = 2;
  options.snapshot_dir = snaps.string();
  options.snapshot_every = 1;
  std::atomic<bool> stop{false};
  const SessionResult r = run_session(*source, options, stop);
  ASSERT_EQ(r.exit_code, ExitCode::kOk) << r.error;
  // The corner fills the whole view of the first frames.
  for (const char* view : {"shaded", "ssao", "normals", "depth"}) {
    const fs::path png = snaps / (std::string(view) + "_000001.png");
    ASSERT_EQ(png_size(png), std::make_pair(640, 480)) << png;
    EXPECT_GT(fraction_unlike_corner(png), 0.5) << png;
  }
  // The model raycast's depth beside them, at the raycast's own size.
  EXPECT_EQ(png_size(snaps / "raycast_depth_000001.png"), std::make_pair(320, 240));
}

/// The RGB pixels of a PNG (empty when unreadable).
Image<Rgb8> read_png(const fs::path& path) {
  png_image image{};
  image.version = PNG_IMAGE_VERSION;
  if (!png_image_begin_read_from_file(&image, path.c_str())) return {};
  image.format = PNG_FORMAT_RGB;
  Image<Rgb8> out(static_cast<int>(image.width), static_cast<int>(image.height));
  if (!png_image_finish_read(&image, nullptr, out.data(), 0, nullptr)) return {};
  return out;
}

/// Runs the processing stages over the frames of `spec` one frame at a time on this thread;
/// `check` sees each frame after the last stage.
void run_stages(Processing& processing, const std::string& spec,
                const std::function<void(const FrameWork&)>& check) {
  std::unique_ptr<Source> source = open_source(spec);
  const std::vector<StageDef> stages = processing.stages();
  FrameWork work;
  for (;;) {
    const Status read = source->read(work.raw);
    if (read.code() == Status::Code::kEndOfStream) break;
    ASSERT_TRUE(read.is_ok()) << read.message();
    for (const StageDef& stage : stages) ASSERT_TRUE(stage.process(work).is_ok()) << stage.name;
    check(work);
  }
}

constexpr const char* kColourCorner =
    "synth:corner?frames=6&width=160&height=120&noise=none&colour=on";

TEST(ModelColour, ComputedOnlyForAViewConsumerAndOnlyWithColour) {
  // Headless without snapshots (the default): no frame gets a colour image, nor view products.
  {
    Processing processing{Config{}};
    int frames = 0;
    run_stages(processing, kColourCorner, [&](const FrameWork& f) {
      ++frames;
      EXPECT_FALSE(f.view_candidate);
      EXPECT_FALSE(f.view_products);
      EXPECT_TRUE(f.model_colour.empty());
    });
    EXPECT_EQ(frames, 6);
  }
  // With a consumer: every tracked frame has one at the raycast's size.
  {
    Processing processing{Config{}};
    processing.set_view_products(true);
    int coloured = 0;
    run_stages(processing, kColourCorner, [&](const FrameWork& f) {
      EXPECT_TRUE(f.view_candidate);
      EXPECT_TRUE(f.view_products);
      ASSERT_TRUE(f.raycast);
      EXPECT_EQ(f.model_colour.width(), f.raycast->depth_m.width());
      EXPECT_EQ(f.model_colour.height(), f.raycast->depth_m.height());
      coloured += !f.model_colour.empty();
    });
    EXPECT_EQ(coloured, 6);
  }
  // With a consumer but no colour fused (fusion.colour=off, or a source without colour): none.
  for (const bool source_colour : {true, false}) {
    Config config;
    if (source_colour) config.fusion.colour = ColourFusion::kOff;
    Processing processing{config};
    processing.set_view_products(true);
    const std::string spec = source_colour ? kColourCorner
                                           : "synth:corner?frames=3&width=160&height=120";
    run_stages(processing, spec, [&](const FrameWork& f) {
      EXPECT_TRUE(f.view_products);
      EXPECT_TRUE(f.model_colour.empty());
    });
  }
}

TEST(ModelColour, ShowsEachPrimitivesTrueColourInsideIt) {
  // Each primitive of the synthetic scene is one flat colour, and the synthetic colour camera is
  // registered and exact: the fused colour at a raycast pixel well inside a primitive (its 7 x 7
  // neighbourhood one colour in the frame's true colour image) is that colour. Tolerance: 4
  // levels per channel (voxel colours are 8-bit running means, blended trilinearly), at 99.5 % of
  // those pixels (room for a voxel that a grazing view coloured across an edge; all of them
  // are within it on this path).
  Processing processing{Config{}};
  processing.set_view_products(true);
  constexpr int kHalf = 3;
  std::size_t inside = 0, close = 0;
  std::set<std::uint32_t> colours_seen;
  run_stages(processing, "synth:corner?frames=10&width=160&height=120&noise=none&colour=on",
             [&](const FrameWork& f) {
               const Image<Rgb8>& truth = f.raw.colour;
               ASSERT_EQ(f.model_colour.width(), truth.width());  // raycast at the frame's size
               for (int y = kHalf; y < truth.height() - kHalf; ++y)
                 for (int x = kHalf; x < truth.width() - kHalf; ++x) {
                   bool uniform = f.raycast->depth_m(x, y) > 0.0f;
                   for (int dy = -kHalf; dy <= kHalf && uniform; ++dy)
                     for (int dx = -kHalf; dx <= kHalf && uniform; ++dx)
                       uniform = truth(x + dx, y + dy) == truth(x, y);
                   if (!uniform) continue;
                   const Rgb8 a = f.model_colour(x, y), b = truth(x, y);
                   ++inside;
                   close += std::abs(a.r - b.r) <= 4 && std::abs(a.g - b.g) <= 4 &&
                            std::abs(a.b - b.b) <= 4;
                   colours_seen.insert(b.r << 16 | b.g << 8 | b.b);
                 }
             });
  std::printf("[ info ] fused colour within 4 levels of the truth at %zu of %zu pixels, %zu "
              "primitive colours\n", close, inside, colours_seen.size());
  ASSERT_GT(inside, 10u * 160 * 120 / 2);  // most of every frame
  EXPECT_GE(colours_seen.size(), 3u);      // several primitives, not one wall
  EXPECT_GE(static_cast<double>(close) / static_cast<double>(inside), 0.995)
      << close << " of " << inside;
}

TEST(ViewStage, ColourSnapshotsShowTheFusedColourOrTheShadedView) {
  // The colour views of snapshots: a coloured corner differs from the shaded grey; without
  // colour (fusion.colour=off) they are the shaded view, pixel for pixel; colour_mvao is never
  // brighter than colour.
  aoscan::testing::ScratchDir scratch;
  for (const bool colour : {true, false}) {
    const fs::path snaps = scratch.path(colour ? "colour_png" : "no_colour_png");
    std::unique_ptr<Source> source = open_source(kColourCorner);
    RunOptions options;
    options.out_dir = scratch.path(colour ? "colour_out" : "no_colour_out").string();
    options.threads = 2;
    options.snapshot_dir = snaps.string();
    options.snapshot_every = 100;
    if (!colour) options.config.fusion.colour = ColourFusion::kOff;
    std::atomic<bool> stop{false};
    const SessionResult r = run_session(*source, options, stop);
    ASSERT_EQ(r.exit_code, ExitCode::kOk) << r.error;
    const Image<Rgb8> shaded = read_png(snaps / "shaded_000005.png");
    const Image<Rgb8> plain = read_png(snaps / "colour_000005.png");
    const Image<Rgb8> with_ao = read_png(snaps / "colour_mvao_000005.png");
    const Image<Rgb8> mvao = read_png(snaps / "mvao_000005.png");
    ASSERT_EQ(shaded.width(), 160);
    ASSERT_EQ(plain.width(), 160);
    ASSERT_EQ(with_ao.width(), 160);
    ASSERT_EQ(mvao.width(), 160);
    if (!colour) {
      EXPECT_EQ(plain, shaded);
      EXPECT_EQ(with_ao, shaded);
      continue;
    }
    std::size_t coloured = 0, darker_or_equal = 0, surface = 0;
    for (int y = 0; y < 120; ++y)
      for (int x = 0; x < 160; ++x) {
        const Rgb8 p = plain(x, y), q = with_ao(x, y), m = mvao(x, y);
        const Rgb8 background = ViewStyle{}.background;
        if (m != background) {
          EXPECT_TRUE(m.r == m.g && m.g == m.b) << "mvao is grey at " << x << "," << y;
        }
        if (p == background) continue;
        ++surface;
        coloured += p.r != p.g || p.g != p.b;
        darker_or_equal += q.r <= p.r && q.g <= p.g && q.b <= p.b;
      }
    EXPECT_GT(surface, 160u * 120 / 2);
    EXPECT_GT(coloured, surface / 2);
    EXPECT_EQ(darker_or_equal, surface);
  }
}

TEST(ViewStage, AConsumerOfSomeViewsGetsOnlyWhatTheyNeed) {
  ViewStageOptions options = window_options();
  options.publish_all_views = false;  // the service's viewers alone
  std::vector<bool> colour_needed;
  options.on_colour_needed = [&colour_needed](bool needed) { colour_needed.push_back(needed); };
  ViewStage view(options);
  // One view product through `stage`, and what it published.
  const auto feed_of = [](ViewStage& stage) {
    FrameWork frame;
    frame.view_products = true;
    EXPECT_TRUE(stage.process(frame).is_ok());
    return stage.take_latest();
  };
  const auto feed = [&] { return feed_of(view); };
  view.set_views({View::kShaded, View::kDepth});
  EXPECT_EQ(colour_needed, std::vector<bool>({false}));
  EXPECT_EQ(feed()->surface, nullptr);  // no orbit viewer: no copy of the cloud
  view.set_views({View::kOrbit, View::kColourMvao});
  EXPECT_EQ(colour_needed, std::vector<bool>({false, true}));
  EXPECT_NE(feed()->surface, nullptr);
  view.set_views({View::kColour});
  EXPECT_EQ(colour_needed.back(), true);
  // The splats view draws the same cloud.
  ViewStage splats(options);
  splats.set_views({View::kShaded});
  EXPECT_EQ(feed_of(splats)->surface, nullptr);
  splats.set_views({View::kSplats});
  EXPECT_NE(feed_of(splats)->surface, nullptr);

  // With a window or snapshots every view is made, whatever set_views() says.
  ViewStageOptions all = window_options();
  bool told = false;
  all.on_colour_needed = [&told](bool) { told = true; };
  ViewStage window(all);
  window.set_views({View::kShaded});
  EXPECT_FALSE(told);
  FrameWork frame;
  frame.view_products = true;
  ASSERT_TRUE(window.process(frame).is_ok());
  EXPECT_NE(window.take_latest()->surface, nullptr);
}

TEST(ViewStage, ASlowWindowNeverBlocksTheChain) {
  ViewStage view(window_options());
  // The "window" takes the newest frame every 50 ms and holds on to every frame it took.
  std::atomic<bool> done{false};
  std::vector<std::shared_ptr<const ViewFrame>> held;
  std::thread window([&] {
    while (!done.load()) {
      if (auto latest = view.mailbox().latest()) held.push_back(latest->first);
      std::this_thread::sleep_for(50ms);
    }
  });
  testing::FakeSource source(100);
  PipelineOptions popts;
  std::atomic<bool> stop{false};
  const auto t0 = std::chrono::steady_clock::now();
  const PipelineResult r = run_pipeline(source,
                                        {{"view",
                                          [&view](FrameWork& f) {
                                            f.view_products = true;  // as the mvao stage marks them
                                            return view.process(f);
                                          }}},
                                        popts, stop);
  const double seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  done.store(true);
  window.join();
  ASSERT_TRUE(r.status.is_ok()) << r.status.message();
  EXPECT_EQ(r.counters.frames_processed, 100u);
  EXPECT_EQ(view.mailbox().version(), 100u);  // every frame was published
  // Waiting for the window would take 100 x 50 ms = 5 s.
  EXPECT_LT(seconds, 2.0);
  const auto latest = view.mailbox().latest();
  ASSERT_TRUE(latest);
  EXPECT_EQ(latest->first->sequence, 99u);
  EXPECT_EQ(latest->first->hud.frames_processed, 100u);
  EXPECT_TRUE(latest->first->depth_m.empty());  // untracked frame: no model view (no data)
}

TEST(ViewStage, FramesWithoutViewProductsAreNotShown) {
  ViewStage view(window_options());
  testing::FakeSource source(10);
  PipelineOptions popts;
  std::atomic<bool> stop{false};
  const PipelineResult r = run_pipeline(source,
                                        {{"view",
                                          [&view](FrameWork& f) {
                                            f.view_products = f.raw.sequence % 2 == 0;
                                            return view.process(f);
                                          }}},
                                        popts, stop);
  ASSERT_TRUE(r.status.is_ok()) << r.status.message();
  EXPECT_EQ(view.frames_seen(), 10u);
  EXPECT_EQ(view.mailbox().version(), 5u);  // frames 0, 2, 4, 6, 8
  EXPECT_EQ(view.mailbox().latest()->first->sequence, 8u);
}

TEST(ViewStage, CaughtUpOnlyOnceTheWindowTookTheLastProduct) {
  ViewStage view(window_options());
  EXPECT_TRUE(view.caught_up(0));  // nothing built yet: build the first
  FrameWork frame;
  frame.view_products = true;
  // One product built (by its producer's count) and not arrived yet: in flight.
  EXPECT_FALSE(view.caught_up(1));
  ASSERT_TRUE(view.process(frame).is_ok());
  EXPECT_FALSE(view.caught_up(1));  // published, not taken by the window
  ASSERT_NE(view.take_latest(), nullptr);
  EXPECT_TRUE(view.caught_up(1));
  // Frames without products count for nothing.
  FrameWork plain;
  ASSERT_TRUE(view.process(plain).is_ok());
  EXPECT_TRUE(view.caught_up(1));
  EXPECT_EQ(view.mailbox().version(), 1u);
}

TEST(ViewStage, ADemandDrivenChainBuildsProductsOnlyForTheWindow) {
  // The mvao stage's rule (Processing::set_view_demand): a frame gets view products when the
  // view stage says the window caught up. A window that never takes a frame gets one product.
  ViewStage view(window_options());
  testing::FakeSource source(30);
  PipelineOptions popts;
  std::atomic<bool> stop{false};
  std::uint64_t built = 0;
  const auto producer = [&](FrameWork& f) {
    f.view_products = view.caught_up(built);
    if (f.view_products) ++built;
    return Status::ok();
  };
  const auto consumer = [&](FrameWork& f) { return view.process(f); };
  PipelineResult r = run_pipeline(source, {{"mvao", producer}, {"view", consumer}}, popts, stop);
  ASSERT_TRUE(r.status.is_ok()) << r.status.message();
  EXPECT_EQ(built, 1u);
  EXPECT_EQ(view.mailbox().version(), 1u);
  // A window that takes every frame soon after it is published is offered more (the producer
  // takes 3 ms a frame, like a stage that has work to do; the window looks every millisecond).
  std::atomic<bool> done{false};
  std::thread window([&] {
    while (!done.load()) {
      view.take_latest();
      std::this_thread::sleep_for(1ms);
    }
  });
  testing::FakeSource more(30);
  const auto slow_producer = [&](FrameWork& f) {
    std::this_thread::sleep_for(3ms);
    return producer(f);
  };
  r = run_pipeline(more, {{"mvao", slow_producer}, {"view", consumer}}, popts, stop);
  done.store(true);
  window.join();
  ASSERT_TRUE(r.status.is_ok()) << r.status.message();
  EXPECT_GE(built, 4u);  // of 30 frames (a loaded machine may wake the window late)
  EXPECT_EQ(view.mailbox().version(), built);  // every product built was published
}

/// A synthetic source that pushes user commands when it reaches given frames and can wait
/// there for a condition, like a user pressing keys during a scan.
class ScriptedSource : public Source {
 public:
  ScriptedSource(const std::string& spec, ViewCommandQueue& commands)
      : inner_(open_source(spec)), commands_(commands) {}
  Status read(DepthFrame& frame) override {
    const std::size_t index = next_++;
    for (const auto& [at, command] : script_)
      if (at == index) commands_.push(command);
    if (wait_at_ == index && wait_for_) {
      const auto until = std::chrono::steady_clock::now() + 10s;
      while (!wait_for_() && std::chrono::steady_clock::now() < until)
        std::this_thread::sleep_for(2ms);
      condition_met_ = wait_for_();
    }
    if (period_.count() > 0 && index > 0) std::this_thread::sleep_for(period_);
    return inner_->read(frame);
  }
  std::string name() const override { return inner_->name(); }
  const Intrinsics& intrinsics() const override { return inner_->intrinsics(); }
  double depth_scale() const override { return inner_->depth_scale(); }
  std::optional<std::size_t> size() const override { return inner_->size(); }
  bool live() const override { return false; }

  std::vector<std::pair<std::size_t, ViewCommand>> script_;
  std::chrono::milliseconds period_{0};
  std::size_t wait_at_ = ~std::size_t{0};
  std::function<bool()> wait_for_;
  bool condition_met_ = false;

 private:
  std::unique_ptr<Source> inner_;
  ViewCommandQueue& commands_;
  std::size_t next_ = 0;
};

constexpr const char* kCorner = "synth:corner?frames=16&width=160&height=120";

RunOptions command_session(const fs::path& out, ViewCommandQueue& commands) {
  RunOptions options;
  options.out_dir = out.string();
  options.threads = 2;
  options.commands = &commands;
  return options;
}

TEST(SessionCommands, PauseStopsIntegrationAndResumeRestartsIt) {
  aoscan::testing::ScratchDir scratch;
  std::atomic<bool> stop{false};
  ViewCommandQueue commands;
  commands.push(ViewCommand::kPauseIntegration);  // before the first frame
  ScriptedSource paused(kCorner, commands);
  const fs::path out = scratch.path("pause");
  const SessionResult r = run_session(paused, command_session(out, commands), stop);
  ASSERT_EQ(r.exit_code, ExitCode::kOk) << r.error;
  EXPECT_EQ(r.pipeline.counters.frames_processed, 16u);
  // Only the first frame, which starts the model (fusion integrates it even when paused), is in
  // the mesh: the same mesh as a one-frame run.
  ViewCommandQueue unused;
  ScriptedSource one("synth:corner?frames=1&width=160&height=120", unused);
  const SessionResult r1 = run_session(one, command_session(scratch.path("one"), unused), stop);
  ASSERT_EQ(r1.exit_code, ExitCode::kOk) << r1.error;
  EXPECT_GT(r1.mesh.vertices, 0u);
  EXPECT_EQ(r.mesh.vertices, r1.mesh.vertices);

  ViewCommandQueue commands2;
  commands2.push(ViewCommand::kPauseIntegration);
  ScriptedSource resumed(kCorner, commands2);
  resumed.script_ = {{4, ViewCommand::kResumeIntegration}};
  resumed.period_ = 20ms;  // time for the command to arrive while frames remain
  const SessionResult r2 =
      run_session(resumed, command_session(scratch.path("resume"), commands2), stop);
  ASSERT_EQ(r2.exit_code, ExitCode::kOk) << r2.error;
  // Frames fused after the resume add blocks (blocks are never freed, and the camera moves on to
  // new parts of the scene) and change the mesh.
  EXPECT_GT(r2.tsdf.blocks, r.tsdf.blocks);
  EXPECT_NE(r2.mesh.vertices, r.mesh.vertices);
}

TEST(SessionCommands, ResetStartsANewModelAndTrajectory) {
  aoscan::testing::ScratchDir scratch;
  std::atomic<bool> stop{false};
  ViewCommandQueue commands;
  ScriptedSource source(kCorner, commands);
  source.script_ = {{6, ViewCommand::kResetModel}};
  source.period_ = 20ms;
  const fs::path out = scratch.path("reset");
  const SessionResult r = run_session(source, command_session(out, commands), stop);
  ASSERT_EQ(r.exit_code, ExitCode::kOk) << r.error;
  EXPECT_EQ(r.processing.model_resets, 1u);
  const std::vector<StampedPose> trajectory = read_trajectory((out / "trajectory.txt").string());
  ASSERT_FALSE(trajectory.empty());
  // The track stage takes the reset before its next frame (capture may be a few frames ahead of
  // it): the trajectory holds only the frames from there on.
  EXPECT_LT(trajectory.size(), 16u);
  EXPECT_GT(trajectory.front().timestamp_s, 0.0);
  EXPECT_NEAR(trajectory.back().timestamp_s, 15.0 / 30.0, 1e-6);
  // The new model's world frame is the camera frame of its first frame.
  EXPECT_LT(trajectory.front().T_world_camera.translation().norm(), 1e-9);
  EXPECT_GT(r.mesh.vertices, 0u);
}

TEST(SessionCommands, WriteOutputsNowWritesTheMeshMidRun) {
  aoscan::testing::ScratchDir scratch;
  std::atomic<bool> stop{false};
  ViewCommandQueue commands;
  ScriptedSource source(kCorner, commands);
  const fs::path out = scratch.path("write_now");
  source.script_ = {{3, ViewCommand::kWriteOutputs}};
  // Frame 8 is read only once mesh.ply, mesh.glb and trajectory.txt exist: they came from `s`.
  source.wait_at_ = 8;
  source.wait_for_ = [&out] {
    return fs::exists(out / "mesh.ply") && fs::exists(out / "mesh.glb") &&
           fs::exists(out / "trajectory.txt");
  };
  const SessionResult r = run_session(source, command_session(out, commands), stop);
  ASSERT_EQ(r.exit_code, ExitCode::kOk) << r.error;
  EXPECT_TRUE(source.condition_met_);
  EXPECT_EQ(r.processing.outputs_written_on_request, 1u);
  EXPECT_EQ(r.pipeline.counters.frames_processed, 16u);
}

TEST(SessionCommands, QuitStopsLikeSigintWithOutputs) {
  aoscan::testing::ScratchDir scratch;
  std::atomic<bool> stop{false};
  ViewCommandQueue commands;
  ScriptedSource source("synth:corner?frames=100000&width=160&height=120", commands);
  source.script_ = {{5, ViewCommand::kQuit}};
  const fs::path out = scratch.path("quit");
  const SessionResult r = run_session(source, command_session(out, commands), stop);
  EXPECT_EQ(r.exit_code, ExitCode::kOk) << r.error;
  EXPECT_TRUE(r.session.quit_by_user);
  EXPECT_GE(r.pipeline.counters.frames_processed, 5u);
  EXPECT_LT(r.pipeline.counters.frames_processed, 1000u);
  EXPECT_EQ(r.pipeline.counters.frames_processed, r.pipeline.counters.frames_read);
  for (const char* f : {"mesh.ply", "trajectory.txt", "stats.json"})
    EXPECT_TRUE(fs::exists(out / f)) << f;
}

}  // namespace
}  // namespace aoscan
