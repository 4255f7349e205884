/// @file main.cpp
/// @brief aoscan-eval: trajectory error (ATE/RPE), mesh accuracy/completeness, mesh colour and AO
/// against ground truth; the AO shown in a replay's snapshot views (image space, temporal
/// stability).
#include <cstdio>
#include <filesystem>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include "core/status.h"
#include "ao_eval.h"
#include "colour_eval.h"
#include "image_eval.h"
#include "io/ply.h"
#include "io/session_files.h"
#include "io/tum.h"
#include "mesh_eval.h"
#include "trajectory_eval.h"

namespace aoscan::eval {
namespace {

int run(int argc, char** argv) {
  CLI::App app{"aoscan-eval: compare aoscan outputs with ground truth"};
  app.require_subcommand(1);

  std::string gt_path, est_path, mesh_path, truth_mesh_path, scene_name;
  double t_max = 0.2;
  std::size_t max_vertices = 20000;
  std::size_t delta = 1;
  double max_dt = 0.02, max_distance = 0.1, threshold = 0.01;
  bool json = false;
  app.add_flag("--json", json, "print one JSON object instead of text");

  CLI::App* traj = app.add_subcommand(
      "trajectory", "ATE (after rigid alignment, no scale) and RPE of EST against GT (TUM format)");
  traj->add_option("GT", gt_path, "ground-truth trajectory")->required()->check(CLI::ExistingFile);
  traj->add_option("EST", est_path, "estimated trajectory (aoscan's trajectory.txt)")
      ->required()->check(CLI::ExistingFile);
  traj->add_option("--delta", delta, "RPE step in frames")->capture_default_str();
  traj->add_option("--max-dt", max_dt, "timestamp association tolerance (s)")->capture_default_str();

  CLI::App* mesh = app.add_subcommand(
      "mesh",
      "accuracy and completeness of MESH against TRUTH; the first pose pair (default) or "
      "the ATE alignment maps MESH into TRUTH's frame");
  mesh->add_option("MESH", mesh_path, "reconstructed mesh (aoscan's mesh.ply)")->required()->check(CLI::ExistingFile);
  mesh->add_option("TRUTH", truth_mesh_path, "ground-truth mesh (a synthetic recording's scene.ply)")
      ->required()->check(CLI::ExistingFile);
  mesh->add_option("--groundtruth", gt_path, "ground-truth trajectory")->required()->check(CLI::ExistingFile);
  mesh->add_option("--estimate", est_path, "estimated trajectory")->required()->check(CLI::ExistingFile);
  mesh->add_option("--max-distance", max_distance, "accuracy cap (m)")->capture_default_str();
  mesh->add_option("--threshold", threshold, "completeness distance (m)")->capture_default_str();

  CLI::App* ao = app.add_subcommand(
      "ao",
      "Pearson r of MESH's per-vertex AO against ray-traced obscurance (Eq. 1) on the exact "
      "geometry of a synthetic scene; the first pose pair (default) or the ATE alignment "
      "maps MESH into it");
  ao->add_option("MESH", mesh_path, "mesh.ply with quality = AO")->required()->check(CLI::ExistingFile);
  ao->add_option("--scene", scene_name, "synthetic scene name (corner, room, plane)")->required();
  ao->add_option("--groundtruth", gt_path, "ground-truth trajectory")->required()->check(CLI::ExistingFile);
  ao->add_option("--estimate", est_path, "estimated trajectory")->required()->check(CLI::ExistingFile);
  ao->add_option("--t-max", t_max, "obscurance falloff distance t_max (m)")->capture_default_str();
  ao->add_option("--vertices", max_vertices, "vertices compared at most")->capture_default_str();
  std::string dump_path;
  ao->add_option("--dump", dump_path,
                 "write the compared vertices as CSV: x,y,z (scene frame, m),mesh_ao,reference");

  CLI::App* colour = app.add_subcommand(
      "colour", "a mesh's vertex colours against the exact colour of a synthetic scene (mean "
                "absolute difference per channel, 0-255)");
  colour->add_option("MESH", mesh_path, "mesh.ply with red, green, blue")->required()->check(CLI::ExistingFile);
  colour->add_option("--scene", scene_name, "synthetic scene name (corner, room, plane)")->required();
  colour->add_option("--groundtruth", gt_path, "ground-truth trajectory")->required()->check(CLI::ExistingFile);
  colour->add_option("--estimate", est_path, "estimated trajectory")->required()->check(CLI::ExistingFile);

  std::string alignment = "first";
  for (CLI::App* sub : {mesh, ao, colour})
    sub->add_option("--alignment", alignment,
                    "how MESH is mapped into the truth's frame: 'first' (the ground-truth pose of "
                    "the estimate's first frame, whose camera frame is aoscan's world frame; "
                    "nothing fitted) or 'ate' (the trajectory's least-squares alignment)")
        ->check(CLI::IsMember({"first", "ate"}))
        ->capture_default_str();

  std::string snapshot_dir, recording_dir, grid_path;
  ImageEvalOptions image_options;
  CLI::App* image = app.add_subcommand(
      "image",
      "per pixel of a replay's snapshot views of a synthetic scene: Pearson r of the frame's "
      "SSAO, the MVAO shown at that frame and the final grid's AO against ray-traced obscurance "
      "at the surface point, over all pixels, near the image border and near depth "
      "discontinuities");
  image->add_option("SNAPSHOTS", snapshot_dir, "--snapshot folder (ssao_*.png, mvao_*.png)")
      ->required()->check(CLI::ExistingDirectory);
  image->add_option("--recording", recording_dir,
                    "the replayed recording (camera.json, depth.txt, groundtruth.txt)")
      ->required()->check(CLI::ExistingDirectory);
  image->add_option("--estimate", est_path, "the replay's trajectory.txt")->required()->check(CLI::ExistingFile);
  image->add_option("--grid", grid_path, "the replay's final MVAO grid (OUT/session/mvao.grid)")
      ->required()->check(CLI::ExistingFile);
  image->add_option("--scene", scene_name, "synthetic scene name (corner, room, plane)")->required();
  image->add_option("--t-max", image_options.t_max_m, "obscurance falloff distance t_max (m)")
      ->capture_default_str();
  image->add_option("--step", image_options.step, "evaluate every N-th raycast pixel along x and y")
      ->check(CLI::PositiveNumber)->capture_default_str();
  image->add_option("--raycast-level", image_options.raycast_level,
                    "the replay's fusion.raycast_level (the views enlarge the raycast by 2^level)")
      ->check(CLI::Range(0, 2))->capture_default_str();
  image->add_option("--border", image_options.border_px, "border region width (px)")->capture_default_str();
  // The final grid read as the replay's views read it (ao.view_read).
  AoViewRead view_read = AoViewRead::kCoarse;
  const std::map<std::string, AoViewRead> view_reads{{"cells", AoViewRead::kCells},
                                                     {"coarse", AoViewRead::kCoarse}};
  const char* view_read_help =
      "how the final grid is read at a point, as the replay's ao.view_read: cells or coarse";
  image->add_option("--view-read", view_read, view_read_help)
      ->transform(CLI::CheckedTransformer(view_reads))
      ->default_str("coarse");
  image->add_option("--discontinuity", image_options.discontinuity_px,
                    "discontinuity region: pixels within this distance of a depth jump (px)")
      ->capture_default_str();

  StabilityOptions stability_options;
  std::size_t min_frames = 10;
  CLI::App* stability = app.add_subcommand(
      "stability",
      "temporal stability of the AO shown in a replay's snapshot views: per world cell (or tracked "
      "point, --track) seen in at least --min-frames snapshot frames, the standard deviation over "
      "those frames of its SSAO "
      "and of its MVAO (surface points: the model raycast's the views show, raycast_depth_*.png, "
      "or the recording's depth, at the estimated poses)");
  stability->add_option("SNAPSHOTS", snapshot_dir, "--snapshot folder (ssao_*.png, mvao_*.png)")
      ->required()->check(CLI::ExistingDirectory);
  stability->add_option("--recording", recording_dir, "the replayed recording (camera.json, depth.txt)")
      ->required()->check(CLI::ExistingDirectory);
  stability->add_option("--estimate", est_path, "the replay's trajectory.txt")->required()->check(CLI::ExistingFile);
  stability->add_option("--cell", stability_options.cell_m, "world cell size (m)")
      ->check(CLI::PositiveNumber)
      ->capture_default_str();
  stability
      ->add_option("--min-frames", min_frames,
                   "cells (or tracked points) seen in fewer frames are left out")
      ->capture_default_str();
  stability->add_option("--grid", grid_path,
                        "the replay's final MVAO grid (OUT/session/mvao.grid): also the spread of "
                        "its AO at the same pixels, and the occluded cells alone")
      ->check(CLI::ExistingFile);
  stability->add_option("--view-read", view_read, view_read_help)
      ->transform(CLI::CheckedTransformer(view_reads))
      ->default_str("coarse");
  bool depth_points = false;
  stability->add_flag("--depth-points", depth_points,
                      "surface points from the recording's depth images even where the snapshots "
                      "have the model raycast's depth (the measure before raycast_depth_*.png)");
  std::string track_path;
  stability
      ->add_option("--track", track_path,
                   "the spread at fixed surface points instead of cells: the vertices of this "
                   "PLY (the replay's mesh.ply), each read where the model raycast shows it")
      ->check(CLI::ExistingFile)
      ->excludes("--depth-points")
      ->excludes("--cell");
  stability
      ->add_option("--every", stability_options.measure_every,
                   "measure the snapshot frames whose number is a multiple of this; with --track "
                   "the others still add to each point's mean of the views so far")
      ->check(CLI::PositiveNumber)
      ->capture_default_str();
  stability
      ->add_option("--from", stability_options.measure_from,
                   "measure the snapshot frames from this frame number on (with --track the "
                   "earlier ones still add to the views so far)")
      ->capture_default_str();

  CLI11_PARSE(app, argc, argv);
  try {
    if (*image || *stability) {
      const std::vector<std::uint64_t> frames = snapshot_frames(snapshot_dir);
      if (frames.empty()) throw input_error(snapshot_dir + ": no frame with ssao and mvao views");
      const Image<float> first = read_shown_ao(snapshot_dir, "ssao", frames.front());
      const RecordingFrames recording = read_recording(recording_dir, first.width(), first.height());
      const std::vector<StampedPose> estimate = read_trajectory(est_path);
      if (*stability) {
        std::optional<MvaoGrid> grid;
        std::optional<FinalGrid> final_grid;
        if (!grid_path.empty()) {
          grid.emplace(grid_from_saved(read_grid(grid_path)));
          final_grid.emplace(*grid, view_read);
        }
        std::vector<Eigen::Vector3f> tracked;
        if (!track_path.empty()) {
          tracked = read_ply(track_path).vertices;
          if (tracked.empty()) throw input_error(track_path + ": no vertex to track");
        }
        const bool tracking = !tracked.empty();
        stability_options.raycast_points = !depth_points;
        if (tracking) stability_options.tracked_points = &tracked;
        const TemporalStability s =
            stability_of_snapshots(snapshot_dir, recording, estimate, stability_options,
                                   final_grid ? &*final_grid : nullptr);
        const TemporalStability::Result r = s.result(min_frames);
        const char* unit = tracking ? "points" : "cells";
        nlohmann::json out;
        out["frames"] = s.frames();
        out["frames_with_raycast_points"] = s.frames_with_raycast_points();
        out["frames_with_depth_points"] = s.frames_with_depth_points();
        if (tracking)
          out["tracked_points"] = tracked.size();
        else
          out["cell_m"] = stability_options.cell_m;
        out["min_frames"] = min_frames;
        out["every"] = stability_options.measure_every;
        out["from"] = stability_options.measure_from;
        const auto spread_json = [&](const TemporalStability::Spread& sp) {
          nlohmann::json o;
          o[unit] = sp.cells;
          o[tracking ? "frames_per_point_mean" : "frames_per_cell_mean"] = sp.frames_per_cell_mean;
          for (int k = 0; k < (grid ? kShownCount : 2); ++k) {
            const std::string name = shown_name(static_cast<Shown>(k));
            o[name + "_std_mean"] = sp.std_mean[k];
            o[name + "_std_median"] = sp.std_median[k];
          }
          if (tracking) {
            o["views_so_far_std_mean"] = sp.std_mean[TemporalStability::kViewsSoFar];
            o["views_so_far_std_median"] = sp.std_median[TemporalStability::kViewsSoFar];
          }
          return o;
        };
        out[unit] = spread_json(r.all);
        if (grid) out[std::string("occluded_") + unit] = spread_json(r.occluded);
        for (const TemporalStability::FinalDifference& d : s.final_differences())
          out["mvao_minus_final_per_frame"].push_back({{"pixels", d.pixels},
                                                       {"mean_abs", d.mean_abs},
                                                       {"share_differing", d.share_differing}});
        if (json) {
          std::printf("%s\n", out.dump(2).c_str());
          return 0;
        }
        if (tracking)
          std::printf(
              "frames              %zu with a pose; of %zu tracked points, those seen in "
              ">= %zu of them\n",
              s.frames(), tracked.size(), min_frames);
        else
          std::printf(
              "frames              %zu with a pose; cells of %.1f cm seen in >= %zu of them\n",
              s.frames(), stability_options.cell_m * 100, min_frames);
        std::printf("surface points      the model raycast's in %zu frames, the recording's depth "
                    "in %zu\n",
                    s.frames_with_raycast_points(), s.frames_with_depth_points());
        std::printf("%-22s %8s %7s %17s %17s", unit, "count", "frames", "SSAO std mean/med",
                    "MVAO std mean/med");
        if (grid) std::printf(" %17s", "final std mean/med");
        if (tracking) std::printf(" %17s", "views so far");
        std::printf("\n");
        const auto row = [&](const char* name, const TemporalStability::Spread& sp) {
          std::printf("%-22s %8zu %7.1f %8.4f/%8.4f %8.4f/%8.4f", name, sp.cells,
                      sp.frames_per_cell_mean, sp.std_mean[0], sp.std_median[0], sp.std_mean[1],
                      sp.std_median[1]);
          if (grid) std::printf(" %8.4f/%8.4f", sp.std_mean[2], sp.std_median[2]);
          constexpr int views = TemporalStability::kViewsSoFar;
          if (tracking) std::printf(" %8.4f/%8.4f", sp.std_mean[views], sp.std_median[views]);
          const auto ratio = [&](int k) {
            return sp.std_mean[0] > 0 ? sp.std_mean[k] / sp.std_mean[0] : 0.0;
          };
          std::printf("  (MVAO / SSAO %.3f", ratio(1));
          if (tracking) std::printf(", views so far / SSAO %.3f", ratio(views));
          std::printf(")\n");
        };
        row("all", r.all);
        if (grid) row("occluded (final < 0.9)", r.occluded);
        if (!s.final_differences().empty()) {
          const TemporalStability::FinalDifference& d = s.final_differences().back();
          std::printf("last frame          MVAO shown - final grid at its pixels: mean |d| %.4f, "
                      "%.1f %% of %zu pixels differ by more than 2/255\n",
                      d.mean_abs, 100 * d.share_differing, d.pixels);
        }
        return 0;
      }
      const std::string gt = (std::filesystem::path(recording_dir) / "groundtruth.txt").string();
      const AssociatedPoses poses = associate_poses(read_trajectory(gt), estimate, max_dt);
      if (poses.estimate.empty()) throw input_error(est_path + ": no pose matches a timestamp of " + gt);
      const MvaoGrid grid = grid_from_saved(read_grid(grid_path));
      const ImageEvalReport report = evaluate_snapshots(
          snapshot_dir, recording, estimate, first_pose_alignment(poses),
          AnalyticScene::make(scene_name), FinalGrid(grid, view_read), image_options);
      nlohmann::json out;
      out["frames"] = report.frames;
      out["frames_untracked"] = report.frames_untracked;
      out["pixels"] = {{"sampled", report.counts.sampled},   {"no_scene", report.counts.no_scene},
                       {"no_ssao", report.counts.no_ssao},   {"no_mvao", report.counts.no_mvao},
                       {"no_final", report.counts.no_final}, {"compared", report.counts.compared}};
      for (int g = 0; g < kRegionCount; ++g) {
        const auto region = static_cast<Region>(g);
        nlohmann::json& o = out["regions"][region_name(region)];
        o["pixels"] = report.pooled.count(region);
        o["mean_reference"] = report.pooled.mean_reference(region);
        for (int k = 0; k < kShownCount; ++k) {
          const auto shown = static_cast<Shown>(k);
          o[std::string("r_") + shown_name(shown)] = report.pooled.r(region, shown);
          o[std::string("mean_") + shown_name(shown)] = report.pooled.mean(region, shown);
        }
      }
      for (int g = 0; g < kRegionCount; ++g)
        out["regions"][region_name(static_cast<Region>(g))]["r_cell_ceiling"] =
            report.cell_ceiling_r[g];
      for (const ImageEvalReport::Frame& f : report.per_frame)
        out["per_frame"].push_back(
            {{"frame", f.sequence}, {"pixels", f.pixels}, {"r_ssao", f.r_ssao}, {"r_mvao", f.r_mvao}});
      if (json) {
        std::printf("%s\n", out.dump(2).c_str());
        return 0;
      }
      std::printf("frames              %zu evaluated (%zu without a pose skipped)\n", report.frames,
                  report.frames_untracked);
      std::printf("pixels              %zu compared of %zu (no scene %zu, no SSAO %zu, unobserved "
                  "MVAO %zu, final grid unobserved %zu)\n",
                  report.counts.compared, report.counts.sampled, report.counts.no_scene,
                  report.counts.no_ssao, report.counts.no_mvao, report.counts.no_final);
      std::printf("Pearson r against the reference; ceiling: the best AO constant over each cell "
                  "of the final grid\n");
      std::printf("%-14s %9s %7s %7s %7s %8s\n", "region", "pixels", "SSAO", "MVAO", "final",
                  "ceiling");
      for (int g = 0; g < kRegionCount; ++g) {
        const auto region = static_cast<Region>(g);
        std::printf("%-14s %9zu %7.3f %7.3f %7.3f %8.3f\n", region_name(region),
                    report.pooled.count(region), report.pooled.r(region, Shown::kSsao),
                    report.pooled.r(region, Shown::kMvao), report.pooled.r(region, Shown::kFinal),
                    report.cell_ceiling_r[g]);
      }
      return 0;
    }
    const AssociatedPoses poses = associate_poses(read_trajectory(gt_path), read_trajectory(est_path), max_dt);
    if (poses.estimate.empty()) throw input_error(est_path + ": no pose matches a timestamp of " + gt_path);
    const AteResult ate = compute_ate(poses);
    nlohmann::json out;
    out["pairs"] = ate.pairs;
    out["ate_rmse_m"] = ate.rmse_m;
    out["ate_mean_m"] = ate.mean_m;
    out["ate_median_m"] = ate.median_m;
    out["ate_max_m"] = ate.max_m;
    out["alignment"] = "rigid (rotation + translation, no scale), least squares on positions";
    const bool first = alignment == "first";
    const Pose T_truth_mesh = first ? first_pose_alignment(poses) : ate.T_truth_estimate;
    const char* mesh_alignment =
        first ? "first pose pair (the world frame is the first frame's camera frame)"
              : "ATE alignment (least squares on positions)";
    if (!*traj) out["mesh_alignment"] = mesh_alignment;
    if (*traj) {
      const RpeResult rpe = compute_rpe(poses, delta);
      out["rpe_delta_frames"] = delta;
      out["rpe_translation_rmse_m"] = rpe.translation_rmse_m;
      out["rpe_rotation_rmse_deg"] = rpe.rotation_rmse_deg;
      if (!json) {
        std::printf("poses matched       %zu\n", ate.pairs);
        std::printf("ATE rmse            %.2f mm (mean %.2f, median %.2f, max %.2f mm)\n", ate.rmse_m * 1e3,
                    ate.mean_m * 1e3, ate.median_m * 1e3, ate.max_m * 1e3);
        std::printf("RPE (%zu frame)      %.2f mm, %.3f deg (rmse)\n", delta, rpe.translation_rmse_m * 1e3,
                    rpe.rotation_rmse_deg);
        std::printf("alignment           rigid (rotation + translation, no scale)\n");
      }
    } else if (*colour) {
      const ColourEvalResult c =
          evaluate_mesh_colour(read_ply(mesh_path), AnalyticScene::make(scene_name), T_truth_mesh);
      out["colour_vertices"] = c.vertices;
      out["colour_off_surface"] = c.off_surface;
      out["colour_mean_abs"] = c.mean_abs;
      out["colour_mean_abs_inside"] = c.mean_abs_inside;
      out["colour_near_edges"] = c.near_edges;
      out["colour_p95_abs"] = c.p95_abs;
      if (!json) {
        std::printf("vertices compared   %zu (%zu farther than 2 cm from the scene skipped; mapped by "
                    "the %s)\n",
                    c.vertices, c.off_surface, mesh_alignment);
        std::printf("colour error        mean %.2f / 255 (p95 %.1f); %.2f / 255 away from the %zu "
                    "vertices within 2 cm of another colour\n",
                    c.mean_abs, c.p95_abs, c.mean_abs_inside, c.near_edges);
      }
    } else if (*ao) {
      const AoEvalResult a = evaluate_mesh_ao(read_ply(mesh_path), AnalyticScene::make(scene_name),
                                              T_truth_mesh, t_max, max_vertices);
      out["ao_vertices"] = a.vertices;
      out["ao_off_surface"] = a.off_surface;
      out["ao_pearson_r"] = a.pearson_r;
      out["ao_rmse"] = a.rmse;
      out["ao_mean_mesh"] = a.mean_mesh;
      out["ao_mean_reference"] = a.mean_reference;
      if (!dump_path.empty()) write_ao_pairs_csv(dump_path, a);
      if (!json) {
        std::printf(
            "vertices compared   %zu (%zu farther than 2 cm from the scene skipped; mapped by "
            "the %s)\n",
            a.vertices, a.off_surface, mesh_alignment);
        std::printf("AO Pearson r        %.3f (rmse %.3f; mean %.3f vs reference %.3f)\n", a.pearson_r,
                    a.rmse, a.mean_mesh, a.mean_reference);
      }
    } else {
      const MeshEvalResult m = evaluate_mesh(read_ply(mesh_path), read_ply(truth_mesh_path),
                                             T_truth_mesh, max_distance, threshold);
      out["vertices"] = m.vertices;
      out["accuracy_mean_m"] = m.accuracy_mean_m;
      out["accuracy_median_m"] = m.accuracy_median_m;
      out["accuracy_p90_m"] = m.accuracy_p90_m;
      out["outlier_fraction"] = m.outlier_fraction;
      out["completeness"] = m.completeness;
      out["completeness_threshold_m"] = threshold;
      if (!json) {
        std::printf("vertices            %zu (mapped by the %s; trajectory ATE %.2f mm)\n",
                    m.vertices, mesh_alignment, ate.rmse_m * 1e3);
        std::printf("accuracy            mean %.2f mm, median %.2f mm, p90 %.2f mm\n",
                    m.accuracy_mean_m * 1e3, m.accuracy_median_m * 1e3, m.accuracy_p90_m * 1e3);
        std::printf("outliers            %.3f %% farther than %.0f mm\n", m.outlier_fraction * 100,
                    max_distance * 1e3);
        std::printf("completeness        %.1f %% of the true surface within %.0f mm\n",
                    m.completeness * 100, threshold * 1e3);
      }
    }
    if (json) std::printf("%s\n", out.dump(2).c_str());
  } catch (const Error& e) {
    std::fprintf(stderr, "aoscan-eval: error: %s\n", e.what());
    return static_cast<int>(e.code());
  }
  return 0;
}

}  // namespace
}  // namespace aoscan::eval

int main(int argc, char** argv) { return aoscan::eval::run(argc, argv); }
