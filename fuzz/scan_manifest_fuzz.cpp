/// @file scan_manifest_fuzz.cpp
/// @brief libFuzzer target: scan manifests of `aoscan scans` (YAML or JSON). The manifest's folder
/// holds itself, `depth.png` and `cloud.ply` (empty), so scans naming them parse to the end.
#include "fuzz/fuzz_input.h"
#include "io/scan_manifest.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace aoscan;
  static fuzz::InputFile file("scans.yaml", {"depth.png", "cloud.ply"});
  const std::string& path = file.write(data, size);
  fuzz::expect_errors(path, [&] {
    for (const ScanEntry& e : read_scan_manifest(path)) {
      fuzz::check_rigid(e.T_world_scan, "scan pose");
      if (e.name.empty() || e.path.empty()) fuzz::bug("scan without a name or path");
      if (e.kind == ScanEntry::Kind::kDepthImage && (!(e.intrinsics.fx > 0) || !(e.depth_scale > 0)))
        fuzz::bug("depth scan with an invalid camera");
      if (!e.scanner.allFinite()) fuzz::bug("scanner position not finite");
    }
  });
  return 0;
}
