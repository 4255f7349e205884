/// @file saved_session.cpp
/// @brief Writing and reading OUT/session/, and continuing a run from it.
#include "pipeline/saved_session.h"

#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>

#include <nlohmann/json.hpp>

#include "core/log.h"
#include "core/status.h"
#include "io/atomic_write.h"
#include "pipeline/processing.h"
#include "pipeline/volume_export.h"

namespace aoscan {
namespace {

namespace fs = std::filesystem;

constexpr const char* kSessionJson = "session.json";
constexpr const char* kVolume = "volume.vdb";
constexpr const char* kGrid = "mvao.grid";
constexpr const char* kKeyframes = "keyframes.db";
constexpr const char* kTrajectory = "trajectory.txt";
constexpr const char* kConfig = "config.yaml";

std::string in_session(const char* name) { return std::string(kSessionFolder) + "/" + name; }

nlohmann::json camera_json(const Intrinsics& k) {
  return {{"width", k.width}, {"height", k.height}, {"fx", k.fx},
          {"fy", k.fy},       {"cx", k.cx},         {"cy", k.cy}};
}

/// One configuration value that must be the same to continue a session.
struct MustMatch {
  const char* key;
  double saved, now;
};

/// The keys whose change would make the saved model, grid or keyframes meaningless.
std::vector<MustMatch> must_match(const Config& saved, const Config& now) {
  return {
      {"fusion.voxel_size_m", saved.fusion.voxel_size_m, now.fusion.voxel_size_m},
      {"fusion.truncation_m", saved.fusion.truncation_m, now.fusion.truncation_m},
      {"ao.grid_extent_m / ao.grid_resolution (the MVAO cell size)",
       saved.ao.grid_extent_m / saved.ao.grid_resolution,
       now.ao.grid_extent_m / now.ao.grid_resolution},
      {"ao.integration", static_cast<double>(saved.ao.integration),
       static_cast<double>(now.ao.integration)},
      {"relocalisation.ferns", static_cast<double>(saved.relocalisation.ferns),
       static_cast<double>(now.relocalisation.ferns)},
      {"relocalisation.fern_decisions", static_cast<double>(saved.relocalisation.fern_decisions),
       static_cast<double>(now.relocalisation.fern_decisions)},
  };
}

/// Writes `text` to `path` atomically.
void write_text(const std::string& path, const std::string& text) {
  write_atomically(path, [&](const std::string& partial) {
    std::ofstream out(partial);
    out << text;
    out.close();
    if (!out) throw Error(ExitCode::kFailure, partial + ": cannot be written");
  });
}

bool same(double a, double b) { return std::abs(a - b) <= 1e-9 * std::max(std::abs(a), 1.0); }

}  // namespace

std::vector<std::string> session_outputs() {
  return {in_session(kVolume),     in_session(kGrid),   in_session(kKeyframes),
          in_session(kTrajectory), in_session(kConfig), in_session(kSessionJson)};
}

void save_session(OutputFolder& outputs, const Processing& processing, const Config& config,
                  const Intrinsics& camera, int takes) {
  std::error_code ec;
  fs::create_directories(outputs.path(kSessionFolder), ec);  // a failure shows in each write
  const Reconstruction& rec = processing.reconstruction();
  outputs.write(in_session(kVolume), [&](const std::string& path) {
    write_volume(path, rec.volume(), &config.fusion, &rec.colour());
  });
  outputs.write(in_session(kGrid), [&](const std::string& path) {
    const MvaoGrid& grid = processing.grid();
    SavedGrid saved;
    saved.cell_size_m = grid.cell_size_m();
    saved.integration = static_cast<std::uint32_t>(grid.integration());
    saved.frames = grid.frames_integrated();
    saved.cells.reserve(grid.cell_count());
    grid.for_each_cell([&](const CellIndex& c, const MvaoCell& cell) {
      saved.cells.push_back(
          {c[0], c[1], c[2], cell.ao_weight_sum, cell.weight_sum, cell.last_frame});
    });
    write_grid(path, saved);
  });
  outputs.write(in_session(kKeyframes), [&](const std::string& path) {
    SavedKeyframes saved;
    saved.ferns = static_cast<std::uint32_t>(config.relocalisation.ferns);
    saved.fern_decisions = static_cast<std::uint32_t>(config.relocalisation.fern_decisions);
    for (const Keyframe& k : rec.relocaliser().database().keyframes())
      saved.keyframes.push_back({k.codes, k.T_world_camera.matrix(), k.depth_mm});
    write_keyframes(path, saved);
  });
  outputs.write(in_session(kTrajectory), [&](const std::string& path) {
    processing.write_trajectory_file(path);
  });
  outputs.write(in_session(kConfig),
                [&](const std::string& path) { write_text(path, dump_config(config)); });
  outputs.write(in_session(kSessionJson), [&](const std::string& path) {
    const nlohmann::json j = {{"format", "aoscan session"},
                              {"version", kSessionFormatVersion},
                              {"camera", camera_json(camera)},
                              {"takes", takes},
                              {"trajectory_poses", processing.trajectory().size()},
                              {"keyframes", rec.relocaliser().database().keyframes().size()}};
    write_text(path, j.dump(2) + "\n");
  });
}

LoadedSession load_session(const std::string& dir, const Config& config) {
  LoadedSession s;
  s.dir = (fs::path(dir) / kSessionFolder).string();
  const auto file = [&](const char* name) { return (fs::path(s.dir) / name).string(); };
  if (!fs::is_directory(s.dir))
    throw input_error("--resume " + dir + ": no saved session (" + s.dir +
                      " is missing; write one with --save-session)");
  nlohmann::json j;
  {
    std::ifstream in(file(kSessionJson));
    if (!in)
      throw input_error(file(kSessionJson) +
                        ": missing (an unfinished or damaged session: its save did not complete)");
    try {
      in >> j;
    } catch (const std::exception&) {
      throw input_error(file(kSessionJson) + ": not valid JSON (a damaged session)");
    }
  }
  try {
    if (j.at("format").get<std::string>() != "aoscan session")
      throw input_error(file(kSessionJson) + ": not an aoscan session");
    const auto version = j.at("version").get<std::uint32_t>();
    if (version != kSessionFormatVersion)
      throw usage_error(file(kSessionJson) + ": session format version " +
                        std::to_string(version) + ", this aoscan reads version " +
                        std::to_string(kSessionFormatVersion));
    const nlohmann::json& c = j.at("camera");
    s.camera = Intrinsics{c.at("width").get<int>(), c.at("height").get<int>(),
                          c.at("fx").get<double>(), c.at("fy").get<double>(),
                          c.at("cx").get<double>(), c.at("cy").get<double>()};
    s.takes = j.at("takes").get<int>();
  } catch (const nlohmann::json::exception& e) {
    throw input_error(file(kSessionJson) + ": " + one_line(e.what()));
  }
  if (!fs::is_regular_file(file(kConfig)))
    throw input_error(file(kConfig) + ": missing (a damaged session)");
  try {
    s.config = load_config(file(kConfig), {});
  } catch (const Error& e) {
    throw input_error(one_line(e.what()) + " (a damaged session)");
  }
  for (const MustMatch& m : must_match(s.config, config))
    if (!same(m.saved, m.now)) {
      std::ostringstream msg;
      msg << "--resume " << dir << ": the session was made with " << m.key << " = " << m.saved
          << ", this run has " << m.now << "; resume with the session's value";
      throw usage_error(msg.str());
    }
  s.volume = read_volume_vdb(file(kVolume));
  s.grid = read_grid(file(kGrid));
  s.keyframes =
      read_keyframes(file(kKeyframes), static_cast<std::size_t>(config.relocalisation.max_keyframes));
  if (s.keyframes.ferns != static_cast<std::uint32_t>(config.relocalisation.ferns) ||
      s.keyframes.fern_decisions != static_cast<std::uint32_t>(config.relocalisation.fern_decisions))
    throw input_error(file(kKeyframes) + ": its ferns differ from the session's configuration");
  s.trajectory = read_trajectory(file(kTrajectory));
  return s;
}

void check_session_camera(const LoadedSession& session, const Intrinsics& camera) {
  const Intrinsics& k = session.camera;
  const bool same_camera = k.width == camera.width && k.height == camera.height &&
                           same(k.fx, camera.fx) && same(k.fy, camera.fy) &&
                           same(k.cx, camera.cx) && same(k.cy, camera.cy);
  if (!same_camera) {
    std::ostringstream msg;
    msg << "--resume " << session.dir << ": the session was seen by a " << k.width << "x"
        << k.height << " camera (fx " << k.fx << ", fy " << k.fy << ", cx " << k.cx << ", cy "
        << k.cy << "), this source is " << camera.width << "x" << camera.height << " (fx "
        << camera.fx << ", fy " << camera.fy << ", cx " << camera.cx << ", cy " << camera.cy
        << "): resume with the same camera";
    throw usage_error(msg.str());
  }
}

void Processing::restore(const LoadedSession& session) {
  std::vector<Keyframe> keyframes;
  keyframes.reserve(session.keyframes.keyframes.size());
  for (const SavedKeyframe& k : session.keyframes.keyframes)
    keyframes.push_back({k.codes, Pose::from_matrix(k.T_world_camera), k.depth_mm});
  reconstruction_.restore(
      [&](TsdfVolume& volume, ColourVolume& colour) {
        load_volume(session.volume, volume, &colour);
      },
      std::move(keyframes));
  grid_.clear();
  if (std::abs(session.grid.cell_size_m - grid_.cell_size_m()) >
      1e-9 * grid_.cell_size_m())
    throw input_error(session.dir + "/" + kGrid + ": its cell size differs from the session's "
                      "configuration");
  for (const SavedCell& c : session.grid.cells)
    if (!grid_.restore_cell({c.x, c.y, c.z}, {c.ao_weight_sum, c.weight_sum, c.last_frame}))
      throw input_error(session.dir + "/" + kGrid + ": a cell outside the grid's range");
  grid_.set_frames_integrated(session.grid.frames);
  trajectory_ = session.trajectory;
  if (session.keyframes.keyframes.empty())
    spdlog::warn("--resume: {} holds no keyframes (saved with relocalisation.ferns=0, or no frame "
                 "was tracked well): the new take has nothing to be relocalised against and "
                 "stays lost",
                 session.dir);
  spdlog::info("--resume: {} ({} takes, {} poses, {} keyframes, {} TSDF bricks, {} MVAO cells); "
               "the first frames are relocalised against it",
               session.dir, session.takes, session.trajectory.size(),
               session.keyframes.keyframes.size(), session.volume.bricks.size(),
               session.grid.cells.size());
}

}  // namespace aoscan
