/// @file ao_acceptance_test.cpp
/// @brief The AO target of the whole pipeline, end to end: a noisy synthetic corner recorded,
/// replayed with tracking on (`mvao` and `last`), and the exported mesh's AO compared with the
/// ray-traced reference exactly as `aoscan-eval ao` does.
#include <filesystem>
#include <string>

#include <gtest/gtest.h>

#include "ao_eval.h"
#include "io/ply.h"
#include "io/tum.h"
#include "sim/synth_scene.h"
#include "support/cli_util.h"
#include "support/scratch_dir.h"
#include "trajectory_eval.h"

namespace aoscan::eval {
namespace {

namespace fs = std::filesystem;
using aoscan::testing::quote;
using aoscan::testing::read_stats;
using aoscan::testing::run_aoscan;

TEST(AoAcceptance, NoisyCornerWithTrackingMeetsTheTargetAndMultiViewBeatsTheLastView) {
#ifdef AOSCAN_SANITIZED
  GTEST_SKIP() << "two 150-frame replays take minutes under the sanitizers; the Release suite "
                  "runs this measurement";
#endif
  aoscan::testing::ScratchDir scratch;
  const fs::path dir = scratch.folder("ao_acceptance");
  const fs::path rec = dir / "rec";
  ASSERT_EQ(run_aoscan("record " + quote("synth:corner?frames=150&noise=kinect&seed=1") + " " +
                           quote(rec.string()),
                       dir)
                .exit_code,
            0);
  const AnalyticScene scene = AnalyticScene::make("corner");
  const auto r_of = [&](const std::string& integration) {
    const fs::path out = dir / integration;
    const auto run =
        run_aoscan("replay " + quote(rec.string()) + " --headless --no-progress --set " +
                       "ao.integration=" + integration + " --out " + quote(out.string()),
                   dir);
    EXPECT_EQ(run.exit_code, 0) << run.err;
    EXPECT_EQ(read_stats(out)["frames_tracking_lost"], 0);
    const AssociatedPoses poses =
        associate_poses(read_trajectory((rec / "groundtruth.txt").string()),
                        read_trajectory((out / "trajectory.txt").string()));
    const AoEvalResult r = evaluate_mesh_ao(read_ply((out / "mesh.ply").string()), scene,
                                            first_pose_alignment(poses), 0.2);
    EXPECT_GT(r.vertices, 15000u);
    EXPECT_LT(r.off_surface, r.vertices / 100) << "vertices without a surface point within 2 cm";
    return r.pearson_r;
  };
  const double mvao = r_of("mvao");
  const double last = r_of("last");
  // Measured 0.912 and 0.906 (BENCHMARKS.md, twelfth round): issue #4's r >= 0.90 with about
  // twice the margin by which a float-level change of the tracking input moves r.
  EXPECT_GE(mvao, 0.90);
  EXPECT_GT(mvao, last);
}

}  // namespace
}  // namespace aoscan::eval
