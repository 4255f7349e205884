/// @file png_fuzz.cpp
/// @brief libFuzzer target: 16-bit grey PNG depth frames (read_grey16_png, behind capture's
/// read_depth_png and the scan sets' depth scans), and its common path against libpng alone: the
/// same status and message, the same pixels.
#include "fuzz/fuzz_input.h"
#include "io/png_read.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace aoscan;
  static fuzz::InputFile file("depth.png");
  const std::string& path = file.write(data, size);
  Image<std::uint16_t> image, by_libpng;
  const Status status = read_grey16_png(path, image, 7);
  const Status libpng_status = detail::read_grey16_png_libpng(path, by_libpng, 7);
  if (status.code() != libpng_status.code() || status.message() != libpng_status.message())
    fuzz::bug("the common path says '" + status.message() + "', libpng '" +
              libpng_status.message() + "'");
  if (status.is_ok()) {
    if (image.width() != by_libpng.width() || image.height() != by_libpng.height())
      fuzz::bug("the common path and libpng decode different sizes");
    for (int y = 0; y < image.height(); ++y)
      for (int x = 0; x < image.width(); ++x)
        if (image.row(y)[x] != by_libpng.row(y)[x])
          fuzz::bug("the common path and libpng decode different pixels");
  }
  if (status.is_ok()) {
    if (image.width() <= 0 || image.height() <= 0) fuzz::bug("decoded an empty image");
    std::uint64_t sum = 0;  // touch every pixel: ASan checks the rows exist
    for (int y = 0; y < image.height(); ++y)
      for (int x = 0; x < image.width(); ++x) sum += image.row(y)[x];
    if (sum == ~std::uint64_t{0}) fuzz::bug("unreachable");
  } else {
    if (status.code() != Status::Code::kCorruptFrame)
      fuzz::bug("unexpected status: " + status.message());
    fuzz::check_message(status.message(), path + " (frame 7)");
  }
  return 0;
}
