/// @file ply_fuzz.cpp
/// @brief libFuzzer target: PLY meshes and point clouds (binary little-endian and ASCII).
#include "fuzz/fuzz_input.h"
#include "io/ply.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace aoscan;
  static fuzz::InputFile file("mesh.ply");
  const std::string& path = file.write(data, size);
  fuzz::expect_errors(path, [&] {
    const TriangleMesh mesh = read_ply(path);
    const std::size_t n = mesh.vertices.size();
    if ((!mesh.normals.empty() && mesh.normals.size() != n) ||
        (!mesh.quality.empty() && mesh.quality.size() != n))
      fuzz::bug("normals or quality do not match the vertices");
    for (const auto& f : mesh.faces)
      for (int k = 0; k < 3; ++k)
        if (f[k] < 0 || static_cast<std::size_t>(f[k]) >= n) fuzz::bug("face index out of range");
  });
  return 0;
}
