/// @file fakenect_dump.cpp
/// @brief write_fakenect_dump(): a Source as INDEX.txt + PGM disparity frames.
#include "capture/fakenect_dump.h"

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <memory>
#include <vector>

#include "capture/kinect_disparity.h"
#include "capture/output_file.h"
#include "capture/read_status.h"

namespace aoscan {

std::string fakenect_depth_file_name(double time_s, std::uint32_t ticks) {
  char name[96];
  std::snprintf(name, sizeof name, "d-%.6f-%u.pgm", time_s, static_cast<unsigned>(ticks));
  return name;
}

std::string fakenect_video_file_name(double time_s, std::uint32_t ticks) {
  char name[96];
  std::snprintf(name, sizeof name, "r-%.6f-%u.ppm", time_s, static_cast<unsigned>(ticks));
  return name;
}

FakenectDumpStats write_fakenect_dump(Source& source, const std::string& dir,
                                      std::optional<std::size_t> max_frames,
                                      const std::atomic<bool>* stop_requested) {
  const std::string root = prepare_output_folder(dir, "INDEX.txt", "a fakenect dump");
  const std::string index_path = root + "/INDEX.txt";

  OutputFile index = open_output(index_path);

  FakenectDumpStats stats;
  DepthFrame frame;
  std::vector<std::uint16_t> disparity(static_cast<std::size_t>(kFakenectWidth) * kFakenectHeight);
  std::optional<double> first_time_s;
  const std::string header = "P5 640 480 65535\n";

  while (!max_frames || stats.frames_written < *max_frames) {
    if (stop_requested && stop_requested->load()) break;
    Status stopped_by;
    const ReadStep step =
        handle_read_status(source.read(frame), ReadPolicy{}, stats.frames_corrupt, stopped_by);
    if (step == ReadStep::kSkip) continue;
    if (step == ReadStep::kStop) {
      if (stopped_by.is_ok()) break;
      close_checked(index, index_path);
      throw_for_status(stopped_by);
    }
    if (frame.depth.width() != kFakenectWidth || frame.depth.height() != kFakenectHeight) {
      close_checked(index, index_path);
      throw input_error(frame.origin + " (frame " + std::to_string(frame.sequence) +
                        "): " + std::to_string(frame.depth.width()) + "x" +
                        std::to_string(frame.depth.height()) +
                        " depth; fakenect replays 640x480 only");
    }

    // Raw units -> mm -> the nearest Kinect disparity, little-endian on disk.
    const double mm_per_unit = 1000.0 / frame.depth_scale;
    const std::uint16_t* in = frame.depth.data();
    for (std::size_t i = 0; i < disparity.size(); ++i) {
      std::uint16_t raw = kKinectRawInvalid;
      if (in[i] != 0) {
        const double mm = std::round(in[i] * mm_per_unit);
        if (mm >= 1.0 && mm <= 65535.0) raw = kinect_mm_to_raw(static_cast<std::uint16_t>(mm));
        if (raw == kKinectRawInvalid) ++stats.pixels_out_of_range;
      }
      const unsigned char le[2] = {static_cast<unsigned char>(raw & 0xff),
                                   static_cast<unsigned char>(raw >> 8)};
      std::memcpy(&disparity[i], le, 2);
    }

    if (!first_time_s) first_time_s = frame.timestamp_s;
    const auto ticks_at = [&](double t) {
      return static_cast<std::uint32_t>(static_cast<std::uint64_t>(
          std::llround(std::max(0.0, t - *first_time_s) * kKinectClockHz)));
    };
    // Writes one dump file (header line, then `count` items of `size` bytes) and lists it.
    const auto write_listed = [&](const std::string& name, const std::string& file_header,
                                  const void* data, std::size_t size, std::size_t count) {
      const std::string path = root + "/" + name;
      {
        OutputFile file = open_output(path);
        if (std::fwrite(file_header.data(), 1, file_header.size(), file.get()) !=
                file_header.size() ||
            std::fwrite(data, size, count, file.get()) != count)
          throw_write_failed(path);
        close_checked(file, path);
      }
      if (std::fprintf(index.get(), "%s\n", name.c_str()) < 0 || std::fflush(index.get()) != 0)
        throw_write_failed(index_path);
    };
    const bool colour = !frame.colour.empty();
    const bool colour_fits =
        frame.colour.width() == kFakenectWidth && frame.colour.height() == kFakenectHeight;
    if (colour && !colour_fits) ++stats.colour_frames_skipped;
    const auto write_video = [&] {
      static_assert(sizeof(Rgb8) == 3, "Rgb8 rows are PPM's RGB rows");
      write_listed(fakenect_video_file_name(frame.colour_timestamp_s,
                                            ticks_at(frame.colour_timestamp_s)),
                   "P6 640 480 255\n", frame.colour.data(), sizeof(Rgb8), frame.colour.size());
      ++stats.colour_frames_written;
    };
    const bool video_first = colour && colour_fits && frame.colour_timestamp_s <= frame.timestamp_s;
    if (video_first) write_video();
    write_listed(fakenect_depth_file_name(frame.timestamp_s, ticks_at(frame.timestamp_s)), header,
                 disparity.data(), sizeof(std::uint16_t), disparity.size());
    if (colour && colour_fits && !video_first) write_video();
    ++stats.frames_written;
  }
  close_checked(index, index_path);
  return stats;
}

}  // namespace aoscan
