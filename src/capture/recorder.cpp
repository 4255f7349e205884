/// @file recorder.cpp
/// @brief record_source(): a Source to a TUM-layout folder, one frame at a time, always consistent.
#include "capture/recorder.h"

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <memory>
#include <optional>

#include <spdlog/spdlog.h>

#include "capture/output_file.h"
#include "capture/png_depth.h"
#include "capture/read_status.h"
#include "capture/timestamp_order.h"
#include "io/camera_json.h"
#include "io/colour_image.h"
#include "io/ply.h"
#include "io/tum.h"

namespace aoscan {
namespace {

namespace fs = std::filesystem;

constexpr ReadPolicy kReadPolicy{/*strict=*/false, /*skip_warning=*/"skipping corrupt frame: "};

}  // namespace

RecordStats record_source(Source& source, const std::string& dir,
                          std::optional<std::size_t> max_frames,
                          const std::atomic<bool>* stop_requested) {
  const std::string root = prepare_output_folder(dir, "depth.txt", "a recording", "depth");
  const std::string list_path = root + "/depth.txt";

  const std::string camera_path = root + "/camera.json";
  Intrinsics calibration = source.intrinsics();
  double depth_scale = source.depth_scale();
  const bool nominal_valid = calibration.valid() && depth_scale > 0;
  if (nominal_valid) write_camera_json(camera_path, calibration, depth_scale);
  bool camera_written = nominal_valid;

  if (const TriangleMesh* mesh = source.scene_mesh()) write_ply(root + "/scene.ply", *mesh);

  OutputFile list = open_output(list_path);
  std::fprintf(list.get(), "# depth maps recorded by aoscan from %s\n# timestamp filename\n",
               one_line(source.name()).c_str());
  if (std::fflush(list.get()) != 0) throw_write_failed(list_path);

  const std::string gt_path = root + "/groundtruth.txt";
  std::unique_ptr<TrajectoryWriter> ground_truth;
  // Colour, from the first frame that has it: rgb/ and rgb.txt, the colour camera in camera.json.
  const std::string colour_list_path = root + "/rgb.txt";
  std::optional<OutputFile> colour_list;
  RecordStats stats;
  DepthFrame frame;
  std::string png_path;
  char name[64];
  std::optional<std::uint64_t> last_sequence;
  TimestampOrder order;

  // Ends the recording: files closed (and checked) before the caller sees the outcome.
  auto finish = [&] {
    close_checked(list, list_path);
    if (colour_list) close_checked(*colour_list, colour_list_path);
    if (ground_truth) ground_truth->close();
  };

  source.watch_stop(stop_requested);
  while (!max_frames || stats.frames_written < *max_frames) {
    if (stop_requested && stop_requested->load()) break;
    const ReadStep step = handle_read_status(source.read(frame), kReadPolicy, stats.frames_corrupt,
                                             stats.stopped_by);
    if (step == ReadStep::kStop) break;
    if (step == ReadStep::kSkip) continue;
    if (const std::optional<std::string> why = order.out_of_order(source, frame)) {
      if (stats.frames_out_of_order++ == 0) warn_first_out_of_order(*why);
      continue;
    }

    // The recording holds one calibration: the first frame may set it, later ones must match.
    const bool consistent_size = frame.depth.width() == frame.intrinsics.width &&
                                 frame.depth.height() == frame.intrinsics.height &&
                                 !frame.depth.empty();
    if (consistent_size && stats.frames_written == 0 &&
        (!camera_written || !(frame.intrinsics == calibration) ||
         frame.depth_scale != depth_scale)) {
      calibration = frame.intrinsics;
      depth_scale = frame.depth_scale;
      write_camera_json(camera_path, calibration, depth_scale);
      camera_written = true;
    }
    if (!consistent_size || !(frame.intrinsics == calibration) ||
        frame.depth_scale != depth_scale) {
      spdlog::warn("skipping frame {} of {}: its calibration differs from {}", frame.sequence,
                   frame.origin, camera_path);
      ++stats.frames_corrupt;
      continue;
    }

    // File names follow the source's sequence; they must grow for the names to stay unique.
    std::uint64_t sequence = frame.sequence;
    if (last_sequence && sequence <= *last_sequence) sequence = *last_sequence + 1;
    last_sequence = sequence;
    // Writes one image of this frame as FOLDER/NNNNNN.png and lists it with `timestamp_s`.
    const auto write_listed = [&](const char* folder, const auto& write, std::FILE* to,
                                  const std::string& to_path, double timestamp_s) {
      std::snprintf(name, sizeof name, "%s/%06llu.png", folder,
                    static_cast<unsigned long long>(sequence));
      png_path.assign(root).append("/").append(name);
      try {
        write(png_path);
      } catch (const Error&) {
        std::error_code ec;
        fs::remove(png_path, ec);  // a partial PNG is never listed; do not leave it either
        finish();
        throw;
      }
      if (std::fprintf(to, "%.6f %s\n", timestamp_s, name) < 0 || std::fflush(to) != 0)
        throw_write_failed(to_path);
    };
    write_listed(
        "depth", [&](const std::string& path) { write_depth_png(path, frame.depth); }, list.get(),
        list_path, frame.timestamp_s);
    if (!frame.colour.empty() && frame.colour_camera) {
      if (!colour_list) {
        write_camera_json(camera_path, calibration, depth_scale, &*frame.colour_camera);
        require_writable_folder(root + "/rgb", root + "/rgb");
        colour_list.emplace(open_output(colour_list_path));
        std::fprintf(colour_list->get(), "# colour images recorded by aoscan from %s\n# timestamp "
                     "filename\n", one_line(source.name()).c_str());
      }
      write_listed(
          "rgb", [&](const std::string& path) { write_colour_png(path, frame.colour); },
          colour_list->get(), colour_list_path, frame.colour_timestamp_s);
    }
    if (frame.T_world_camera_gt) {
      if (!ground_truth)
        ground_truth = std::make_unique<TrajectoryWriter>(
            gt_path, "ground truth of " + one_line(source.name()) +
                         " (camera-to-world)\ntimestamp tx ty tz qx qy qz qw");
      ground_truth->write({frame.timestamp_s, *frame.T_world_camera_gt});
    }
    ++stats.frames_written;
  }
  finish();
  if (!camera_written && !stats.stopped_by.is_ok()) throw_for_status(stats.stopped_by);
  if (!camera_written)
    throw input_error(source.name() + ": no frame with a valid calibration to write " +
                      camera_path);
  return stats;
}

}  // namespace aoscan
