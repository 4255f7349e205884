/// @file meshlab_project_fuzz.cpp
/// @brief libFuzzer target: MeshLab projects (`.mlp`). The project's folder holds itself and
/// `cloud.ply` (empty), so layers naming it parse to the end.
#include "fuzz/fuzz_input.h"
#include "io/meshlab_project.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace aoscan;
  static fuzz::InputFile file("project.mlp", {"cloud.ply"});
  const std::string& path = file.write(data, size);
  fuzz::expect_errors(path, [&] {
    for (const ScanEntry& e : read_meshlab_project(path)) {
      fuzz::check_rigid(e.T_world_scan, "layer pose");
      if (e.name.empty() || e.kind != ScanEntry::Kind::kPointCloud) fuzz::bug("bad layer");
    }
  });
  return 0;
}
