/// @file saved_session.h
/// @brief A session saved to continue later (`--save-session`, `--resume DIR`): the folder
/// `OUT/session/` with the TSDF (volume.vdb), the MVAO grid (mvao.grid), the keyframe database
/// (keyframes.db), the trajectory (trajectory.txt), the effective configuration (config.yaml) and
/// session.json (format version, aoscan version, camera, counts), written last: a folder without
/// it is an unfinished save.
#pragma once

#include <string>
#include <vector>

#include "core/intrinsics.h"
#include "io/session_files.h"
#include "io/tum.h"
#include "io/vdb.h"
#include "pipeline/config.h"
#include "pipeline/output_folder.h"

namespace aoscan {

class Processing;

/// The session folder's name inside --out.
inline constexpr const char* kSessionFolder = "session";

/// Everything a saved session holds, read back.
struct LoadedSession {
  std::string dir;  ///< DIR/session
  Config config;    ///< the configuration it was made with
  Intrinsics camera;
  int takes = 0;  ///< takes fused into it so far
  VolumeData volume;
  SavedKeyframes keyframes;
  SavedGrid grid;
  std::vector<StampedPose> trajectory;
};

/// Reads `dir`/session/ and checks it against this run's `config`: throws input_error (exit 3)
/// naming the file for a missing, unfinished (no session.json), truncated or damaged session, and
/// usage_error (exit 2) for a session of another format version or one made with another voxel
/// size, truncation, MVAO grid or ferns than `config` has (naming the keys and both values).
LoadedSession load_session(const std::string& dir, const Config& config);

/// Throws usage_error when this run's camera differs from the session's (its keyframes and
/// model were seen by that camera): resolution or focal length and centre beyond 1e-6.
void check_session_camera(const LoadedSession& session, const Intrinsics& camera);

/// Writes `outputs`' folder/session/ from `processing` (read after the chain has stopped): each
/// file through `outputs` (so a failure is recorded and the others still written), session.json
/// last. `camera`: the intrinsics of the frames; `takes`: the takes fused so far, this one
/// included.
void save_session(OutputFolder& outputs, const Processing& processing, const Config& config,
                  const Intrinsics& camera, int takes);

/// The names save_session() writes, relative to the output folder, session.json last.
std::vector<std::string> session_outputs();

}  // namespace aoscan
