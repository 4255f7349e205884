/// @file main.cpp
/// @brief aoscan-fakenect-dump SOURCE DIR [--frames N]: any source as a fakenect dump, so the live
/// libfreenect path can be exercised without a Kinect (FAKENECT_PATH=DIR + fakenect's library).
#include <cstdio>
#include <optional>
#include <string>

#include <CLI/CLI.hpp>

#include "capture/fakenect_dump.h"
#include "capture/source.h"
#include "core/status.h"

int main(int argc, char** argv) {
  CLI::App app{
      "Writes any aoscan SOURCE (640x480 depth) as a fakenect dump: INDEX.txt + d-*.pgm "
      "Kinect v1 disparity frames. Replay it with FAKENECT_PATH=DIR and "
      "LD_LIBRARY_PATH=<libdir>/fakenect, e.g. aoscan scan --device freenect."};
  std::string source_spec;
  std::string dir;
  std::optional<std::size_t> max_frames;
  app.add_option("SOURCE", source_spec, "TUM folder, synth:NAME[?...], .oni or camera")->required();
  app.add_option("DIR", dir, "dump folder to create")->required();
  app.add_option("--frames", max_frames, "write at most N frames")->check(CLI::PositiveNumber);
  try {
    app.parse(argc, argv);
  } catch (const CLI::CallForHelp& e) {
    return app.exit(e);
  } catch (const CLI::ParseError& e) {
    std::fprintf(stderr, "aoscan-fakenect-dump: error: %s\n", e.what());
    return static_cast<int>(aoscan::ExitCode::kUsage);
  }
  try {
    auto source = aoscan::open_source(source_spec);
    const aoscan::FakenectDumpStats stats =
        aoscan::write_fakenect_dump(*source, dir, max_frames, nullptr);
    std::fprintf(stderr, "aoscan-fakenect-dump: wrote %zu frames to %s", stats.frames_written,
                 dir.c_str());
    if (stats.frames_corrupt > 0)
      std::fprintf(stderr, " (%zu unreadable skipped)", stats.frames_corrupt);
    if (stats.colour_frames_written > 0)
      std::fprintf(stderr, " with %zu RGB frames", stats.colour_frames_written);
    if (stats.colour_frames_skipped > 0)
      std::fprintf(stderr, " (%zu colour frames not 640x480 left out)", stats.colour_frames_skipped);
    if (stats.pixels_out_of_range > 0)
      std::fprintf(stderr, " (%zu depths outside the Kinect's range written invalid)",
                   stats.pixels_out_of_range);
    std::fputc('\n', stderr);
    if (stats.frames_written == 0) {
      std::fprintf(stderr, "aoscan-fakenect-dump: error: %s: no usable frame\n",
                   source_spec.c_str());
      return static_cast<int>(aoscan::ExitCode::kBadInput);
    }
  } catch (const aoscan::Error& e) {
    std::fprintf(stderr, "aoscan-fakenect-dump: error: %s\n", e.what());
    return static_cast<int>(e.code());
  } catch (const std::exception& e) {
    std::fprintf(stderr, "aoscan-fakenect-dump: error: %s\n", e.what());
    return static_cast<int>(aoscan::ExitCode::kFailure);
  }
  return 0;
}
