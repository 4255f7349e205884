/// @file session_files_fuzz.cpp
/// @brief libFuzzer target: a saved session's keyframe and MVAO grid files (the first input byte
/// picks which reader; the rest is the file).
#include <cmath>

#include "fuzz/fuzz_input.h"
#include "io/session_files.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace aoscan;
  if (size == 0) return 0;
  static fuzz::InputFile file("session.bin");
  const std::string& path = file.write(data + 1, size - 1);
  fuzz::expect_errors(path, [&] {
    if (data[0] & 1) {
      const SavedGrid grid = read_grid(path);
      if (!(grid.cell_size_m > 0.0) || !std::isfinite(grid.cell_size_m))
        fuzz::bug("a grid with a bad cell size");
      for (const SavedCell& c : grid.cells)
        if (!std::isfinite(c.weight_sum) || c.weight_sum < 0.0f) fuzz::bug("a bad cell weight");
    } else {
      const SavedKeyframes k = read_keyframes(path, 1000);
      for (const SavedKeyframe& f : k.keyframes) {
        if (f.codes.size() != k.ferns) fuzz::bug("a keyframe with the wrong number of codes");
        if (!f.T_world_camera.allFinite()) fuzz::bug("a non-finite keyframe pose");
      }
    }
  });
  return 0;
}
