/// @file ptx_fuzz.cpp
/// @brief libFuzzer target: PTX laser scans.
#include "fuzz/fuzz_input.h"
#include "io/ptx.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace aoscan;
  static fuzz::InputFile file("scan.ptx");
  const std::string& path = file.write(data, size);
  fuzz::expect_errors(path, [&] {
    for (const PtxScan& scan : read_ptx(path)) {
      fuzz::check_rigid(scan.T_world_scanner, "PTX registration");
      if (scan.columns < 1 || scan.rows < 1 ||
          static_cast<long long>(scan.points.size()) + scan.missing !=
              static_cast<long long>(scan.columns) * scan.rows)
        fuzz::bug("PTX scan's points and missing cells do not fill its grid");
    }
  });
  return 0;
}
