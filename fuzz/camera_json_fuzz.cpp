/// @file camera_json_fuzz.cpp
/// @brief libFuzzer target: camera.json of a recording folder (also what `aoscan record` writes).
#include "fuzz/fuzz_input.h"
#include "io/camera_json.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace aoscan;
  static fuzz::InputFile file("camera.json");
  const std::string& path = file.write(data, size);
  fuzz::expect_errors(path, [&] {
    const CameraInfo info = read_camera_json(path, 640, 480);
    if (!info.intrinsics.valid() || !(info.depth_scale > 0))
      fuzz::bug("read_camera_json accepted an invalid calibration");
  });
  return 0;
}
