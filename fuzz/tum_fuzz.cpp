/// @file tum_fuzz.cpp
/// @brief libFuzzer target: TUM file lists (depth.txt, also what `aoscan record` writes) and TUM
/// trajectories (groundtruth.txt), read from the same bytes.
#include <cmath>

#include "fuzz/fuzz_input.h"
#include "io/tum.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace aoscan;
  static fuzz::InputFile file("depth.txt");
  const std::string& path = file.write(data, size);
  fuzz::expect_errors(path, [&] {
    for (const TumListEntry& e : read_tum_list(path))
      if (e.path.empty() || e.line < 1) fuzz::bug("list entry without a path or line");
  });
  fuzz::expect_errors(path, [&] {
    for (const StampedPose& p : read_trajectory(path)) {
      if (!std::isfinite(p.timestamp_s)) fuzz::bug("trajectory timestamp not finite");
      fuzz::check_rigid(p.T_world_camera, "trajectory pose");
    }
  });
  return 0;
}
