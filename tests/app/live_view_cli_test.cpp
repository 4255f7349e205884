// End-to-end tests of the live view wiring in the aoscan executable: the no-display fall-back,
// --snapshot in headless replay, a replay with the window, and the failures mid-run: a GL too old,
// the display going away, the user closing the window (each on a private Xvfb).
#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <set>
#include <string>
#include <thread>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "support/cli_util.h"
#include "support/private_xvfb.h"
#include "support/scratch_dir.h"
// Last: Xlib's macros (Status, Bool, None) must not reach the headers above.
#include <X11/Xatom.h>
#include <X11/Xlib.h>

namespace fs = std::filesystem;

namespace {

using aoscan::testing::AoscanProcess;
using aoscan::testing::count;
using aoscan::testing::PrivateXvfb;
using aoscan::testing::quote;
using aoscan::testing::read_stats;
using aoscan::testing::read_text;
using aoscan::testing::run_aoscan;

constexpr const char* kSynth = "'synth:corner?frames=8&width=160&height=120'";

#ifdef AOSCAN_SANITIZED
// Mesa's GL driver allocates at load and is unloaded by glfwTerminate() (or, after a lost display,
// never released): LeakSanitizer then reports its blocks from an "unknown module". Leaks of our own
// code are checked everywhere else; the window runs check behaviour and outputs.
constexpr const char* kWindowEnv = "ASAN_OPTIONS=detect_leaks=0:abort_on_error=1";
#else
constexpr const char* kWindowEnv = "";
#endif

/// A replay long enough to act on while it runs: 450 frames paced at 30 Hz (15 s). Under the
/// sanitizers, with other tests beside it, the low-priority window thread may take seconds to
/// map its window; the run must still be going when the test then closes the display.
constexpr const char* kLongRealtimeSynth = "'synth:corner?frames=450&width=160&height=120'";
constexpr int kLongFrames = 450;
/// A 20 s realtime replay for the close test: the window thread runs at a low priority, and on a
/// loaded machine (two sanitized tests at once) it may take seconds to handle the close; the run
/// must still be going then. A working close ends it within a second or two.
constexpr const char* kCloseSynth = "'synth:corner?frames=600&width=160&height=120'";
constexpr int kCloseFrames = 600;

void expect_outputs(const fs::path& out, int frames) {
  for (const char* f : {"mesh.ply", "trajectory.txt", "stats.json"})
    EXPECT_TRUE(fs::exists(out / f)) << f;
  const auto stats = read_stats(out);
  EXPECT_EQ(stats["frames_processed"], frames);
}

/// An X client of the test itself, to see and poke aoscan's window. Its own connection is closed
/// before the server is taken away (Xlib would otherwise end the test process).
class XClient {
 public:
  explicit XClient(const std::string& display) : display_(XOpenDisplay(display.c_str())) {}
  ~XClient() { close(); }
  XClient(const XClient&) = delete;
  XClient& operator=(const XClient&) = delete;
  void close() {
    if (display_) XCloseDisplay(display_);
    display_ = nullptr;
  }
  bool connected() const { return display_ != nullptr; }

  /// The first mapped top-level window whose title starts with "aoscan" (0 when none yet).
  Window aoscan_window() {
    Window root = DefaultRootWindow(display_);
    Window parent = 0;
    Window* children = nullptr;
    unsigned int n = 0;
    if (!XQueryTree(display_, root, &root, &parent, &children, &n)) return 0;
    Window found = 0;
    for (unsigned int i = 0; i < n && !found; ++i) {
      XWindowAttributes attributes{};
      if (!XGetWindowAttributes(display_, children[i], &attributes) ||
          attributes.map_state != IsViewable)
        continue;
      char* name = nullptr;
      if (XFetchName(display_, children[i], &name) && name) {
        if (std::string(name).rfind("aoscan", 0) == 0) found = children[i];
        XFree(name);
      }
    }
    if (children) XFree(children);
    return found;
  }

  /// Waits up to `timeout` for aoscan's window to be shown.
  Window wait_for_aoscan_window(std::chrono::seconds timeout) {
    const auto deadline = std::chrono::steady_clock::now() + timeout;
    while (std::chrono::steady_clock::now() < deadline) {
      if (const Window w = aoscan_window()) return w;
      std::this_thread::sleep_for(std::chrono::milliseconds(50));
    }
    return 0;
  }

  /// What a window manager sends when the user clicks the window's close button.
  void request_close(Window window) {
    XEvent event{};
    event.xclient.type = ClientMessage;
    event.xclient.window = window;
    event.xclient.message_type = XInternAtom(display_, "WM_PROTOCOLS", False);
    event.xclient.format = 32;
    event.xclient.data.l[0] = static_cast<long>(XInternAtom(display_, "WM_DELETE_WINDOW", False));
    event.xclient.data.l[1] = CurrentTime;
    XSendEvent(display_, window, False, NoEventMask, &event);
    XFlush(display_);
  }

 private:
  Display* display_ = nullptr;
};

/// When the window never showed: a skip if the display has no usable GL, else a failure.
void skip_or_fail_without_window(const aoscan::testing::CliRun& r) {
  if (r.err.find("live view unavailable") != std::string::npos)
    GTEST_SKIP() << "the display has no usable GL: " << r.err;
  FAIL() << "aoscan's window never showed (exit " << r.exit_code << "): " << r.err;
}

TEST(LiveViewCli, NoDisplayFallsBackToHeadlessWithOneWarning) {
  aoscan::testing::ScratchDir scratch;
  for (const std::string env :
       {"env -u DISPLAY -u WAYLAND_DISPLAY", "env -u WAYLAND_DISPLAY DISPLAY=:bogus.0"}) {
    SCOPED_TRACE(env);
    const fs::path dir = scratch.folder("live_nodisplay");
    const auto r = run_aoscan(
        std::string("replay ") + kSynth + " --no-progress --out " + quote((dir / "out").string()),
        dir, env);
    EXPECT_EQ(r.exit_code, 0) << r.err;
    EXPECT_EQ(count(r.err, "\n"), 1u) << r.err;  // exactly one line on stderr
    EXPECT_EQ(count(r.err, "aoscan: warning: live view unavailable"), 1u) << r.err;
    EXPECT_NE(r.err.find("continuing headless"), std::string::npos) << r.err;
    expect_outputs(dir / "out", 8);
  }
}

TEST(LiveViewCli, HeadlessSnapshotsEveryNthFrameAndTheLast) {
  aoscan::testing::ScratchDir scratch;
  const fs::path dir = scratch.folder("live_snapshots");
  const auto r =
      run_aoscan(std::string("replay ") + kSynth + " --headless --no-progress --snapshot " +
                     quote((dir / "png").string()) + " --snapshot-every 4 --out " +
                     quote((dir / "out").string()),
                 dir, "env -u DISPLAY -u WAYLAND_DISPLAY");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_TRUE(r.err.empty()) << r.err;  // --headless: not even a warning
  std::set<std::string> names;
  for (const auto& e : fs::directory_iterator(dir / "png")) {
    names.insert(e.path().filename().string());
    EXPECT_GT(fs::file_size(e.path()), 100u) << e.path();
  }
  std::set<std::string> expected;
  for (const char* view :
       {"shaded", "ssao", "mvao", "colour", "colour_mvao", "normals", "depth", "orbit", "splats",
        "raycast_depth"})
    for (const char* seq : {"000000", "000004", "000007"})
      expected.insert(std::string(view) + "_" + seq + ".png");
  EXPECT_EQ(names, expected);
  expect_outputs(dir / "out", 8);
  EXPECT_EQ(read_stats(dir / "out")["snapshot_files"], 30);

  // Deterministic: a second run writes the same images.
  const auto again =
      run_aoscan(std::string("replay ") + kSynth + " --headless --no-progress --snapshot " +
                     quote((dir / "png2").string()) + " --snapshot-every 4 --out " +
                     quote((dir / "out2").string()),
                 dir);
  ASSERT_EQ(again.exit_code, 0) << again.err;
  for (const std::string& name : expected)
    EXPECT_EQ(read_text(dir / "png" / name), read_text(dir / "png2" / name)) << name;
}

TEST(LiveViewCli, ReplayWithTheWindowWritesTheSameOutputs) {
  aoscan::testing::ScratchDir scratch;
  PrivateXvfb x;
  if (!x.running()) GTEST_SKIP() << "no private display: " << x.error();
  const fs::path dir = scratch.folder("live_window");
  const auto shown = run_aoscan(std::string("--log-level info replay ") + kSynth +
                                    " --no-progress --out " + quote((dir / "w").string()),
                                dir, std::string(kWindowEnv) + " DISPLAY=" + x.display());
  ASSERT_EQ(shown.exit_code, 0) << shown.err;
  if (shown.err.find("live view unavailable") != std::string::npos)
    GTEST_SKIP() << "the display has no usable GL: " << shown.err;
  EXPECT_NE(shown.err.find("live view open on " + x.display()), std::string::npos) << shown.err;
  EXPECT_NE(shown.err.find("live view closed"), std::string::npos) << shown.err;
  expect_outputs(dir / "w", 8);
  EXPECT_EQ(read_stats(dir / "w")["live_view"], "shown");
  const auto headless =
      run_aoscan(std::string("replay ") + kSynth + " --headless --no-progress --out " +
                     quote((dir / "h").string()),
                 dir);
  ASSERT_EQ(headless.exit_code, 0) << headless.err;
  EXPECT_EQ(read_stats(dir / "h")["live_view"], "none");
  // The window only reads: fusion's outputs are byte-identical.
  for (const char* f : {"mesh.ply", "trajectory.txt"})
    EXPECT_EQ(read_text(dir / "w" / f), read_text(dir / "h" / f)) << f;
}

TEST(LiveViewCli, TooOldOpenGlFallsBackToHeadlessWithOneWarning) {
  aoscan::testing::ScratchDir scratch;
  // Mesa caps the versions it offers at MESA_GL_VERSION_OVERRIDE: the real 3.3 core context
  // request through GLFW and GLX then fails, as on a machine whose driver only has GL 2.1.
  PrivateXvfb x;
  if (!x.running()) GTEST_SKIP() << "no private display: " << x.error();
  const fs::path dir = scratch.folder("live_oldgl");
  const std::string display = std::string(kWindowEnv) + " DISPLAY=" + x.display();
  const auto control = run_aoscan(
      std::string("replay ") + kSynth + " --no-progress --out " + quote((dir / "control").string()),
      dir, display);
  ASSERT_EQ(control.exit_code, 0) << control.err;
  if (!control.err.empty())
    GTEST_SKIP() << "no GL 3.3 on Xvfb even without the override: " << control.err;
  const auto r = run_aoscan(
      std::string("replay ") + kSynth + " --no-progress --out " + quote((dir / "out").string()),
      dir, display + " MESA_GL_VERSION_OVERRIDE=2.1 MESA_GLSL_VERSION_OVERRIDE=120");
  EXPECT_EQ(r.exit_code, 0) << r.err;
  EXPECT_EQ(count(r.err, "\n"), 1u) << r.err;  // exactly one line on stderr
  EXPECT_EQ(count(r.err,
                  "aoscan: warning: live view unavailable: cannot create an OpenGL 3.3 "
                  "core context"),
            1u)
      << r.err;
  EXPECT_NE(r.err.find("; continuing headless"), std::string::npos) << r.err;
  expect_outputs(dir / "out", 8);
  EXPECT_EQ(read_stats(dir / "out")["live_view"], "none");
  for (const char* f : {"mesh.ply", "trajectory.txt"})
    EXPECT_EQ(read_text(dir / "out" / f), read_text(dir / "control" / f)) << f;
}

TEST(LiveViewCli, DisplayClosingMidRunContinuesHeadless) {
  aoscan::testing::ScratchDir scratch;
  PrivateXvfb x;
  if (!x.running()) GTEST_SKIP() << "no private display: " << x.error();
  const fs::path dir = scratch.folder("live_display_lost");
  AoscanProcess run(std::string("replay ") + kLongRealtimeSynth +
                        " --realtime --no-progress --out " + quote((dir / "out").string()),
                    dir, std::string(kWindowEnv) + " DISPLAY=" + x.display());
  ASSERT_TRUE(run.started());
  {
    XClient client(x.display());
    ASSERT_TRUE(client.connected()) << x.display();
    if (!client.wait_for_aoscan_window(std::chrono::seconds(30))) {
      run.wait_for(std::chrono::seconds(60));
      skip_or_fail_without_window(run.output());
      return;
    }
  }  // the test's own connection ends before the server does
  std::this_thread::sleep_for(std::chrono::milliseconds(300));  // a few redraws
  ASSERT_FALSE(run.poll()) << "the replay ended before the display went away";
  x.stop();
  const std::optional<int> code = run.wait_for(std::chrono::seconds(60));
  ASSERT_TRUE(code) << "aoscan hangs after its display went away";
  const auto r = run.output();
  EXPECT_EQ(*code, 0) << r.err;
  EXPECT_EQ(count(r.err, "\n"), 1u) << r.err;  // exactly one line on stderr
  EXPECT_EQ(count(r.err, "aoscan: warning: live view lost: the display " + x.display() +
                             " closed; continuing headless"),
            1u)
      << r.err;
  const auto stats = read_stats(dir / "out");
  EXPECT_EQ(stats["live_view"], "display_lost");
  EXPECT_EQ(stats["quit_by_user"], false);
  EXPECT_EQ(stats["frames_read"], kLongFrames) << "the run went on to the end of the recording";
  EXPECT_EQ(stats["frames_processed"].get<int>() + stats["frames_dropped"].get<int>(), kLongFrames);
  EXPECT_GT(stats["mesh"]["faces"].get<int>(), 100);
  EXPECT_GT(fs::file_size(dir / "out" / "trajectory.txt"), 0u);
}

TEST(LiveViewCli, ClosingTheWindowStopsLikeQAndWritesOutputs) {
  aoscan::testing::ScratchDir scratch;
  PrivateXvfb x;
  if (!x.running()) GTEST_SKIP() << "no private display: " << x.error();
  const fs::path dir = scratch.folder("live_close");
  AoscanProcess run(std::string("replay ") + kCloseSynth +
                        " --realtime --no-progress --out " + quote((dir / "out").string()),
                    dir, std::string(kWindowEnv) + " DISPLAY=" + x.display());
  ASSERT_TRUE(run.started());
  XClient client(x.display());
  ASSERT_TRUE(client.connected()) << x.display();
  const Window window = client.wait_for_aoscan_window(std::chrono::seconds(30));
  if (!window) {
    run.wait_for(std::chrono::seconds(60));
    skip_or_fail_without_window(run.output());
    return;
  }
  std::this_thread::sleep_for(std::chrono::milliseconds(300));
  ASSERT_FALSE(run.poll()) << "the replay ended before the window was closed";
  client.request_close(window);
  const std::optional<int> code = run.wait_for(std::chrono::seconds(60));
  ASSERT_TRUE(code) << "aoscan did not stop after its window was closed";
  const auto r = run.output();
  EXPECT_EQ(*code, 0) << r.err;
  EXPECT_TRUE(r.err.empty()) << r.err;
  const auto stats = read_stats(dir / "out");
  EXPECT_EQ(stats["quit_by_user"], true);
  EXPECT_EQ(stats["live_view"], "shown");
  EXPECT_LT(stats["frames_read"].get<int>(), kCloseFrames) << "capture stopped at the close";
  EXPECT_EQ(stats["frames_processed"].get<int>() + stats["frames_dropped"].get<int>(),
            stats["frames_read"].get<int>())
      << "the frames in flight were finished";
  EXPECT_GT(fs::file_size(dir / "out" / "mesh.ply"), 0u);
  EXPECT_GT(fs::file_size(dir / "out" / "trajectory.txt"), 0u);
}

}  // namespace
