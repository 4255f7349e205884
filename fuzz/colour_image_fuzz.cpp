/// @file colour_image_fuzz.cpp
/// @brief libFuzzer target: colour images of recordings (read_colour_image, behind the TUM
/// source's rgb.txt frames): whatever OpenCV decodes becomes 8-bit RGB, anything else a one-line
/// corrupt frame. The input's first two bytes are the colour camera's size the reader expects
/// (width and height 1-256, as the TUM source passes its colour camera's), the rest the file: an
/// image the reader decodes has that size, so an execution decodes at most 256 x 256 pixels.
#include "fuzz/fuzz_input.h"
#include "io/colour_image.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace aoscan;
  if (size < 2) return 0;
  const ExpectedSize expected{1 + data[0], 1 + data[1]};
  static fuzz::InputFile file("colour.img");
  const std::string& path = file.write(data + 2, size - 2);
  Image<Rgb8> image;
  const Status status = read_colour_image(path, image, 7, expected);
  if (status.is_ok()) {
    if (image.width() != expected.width || image.height() != expected.height)
      fuzz::bug("decoded an image of another size than expected");
    unsigned sum = 0;  // touch every pixel: ASan checks the rows exist
    for (int y = 0; y < image.height(); ++y)
      for (int x = 0; x < image.width(); ++x) sum += image.row(y)[x].g;
    if (sum == ~0u) fuzz::bug("unreachable");
  } else {
    if (status.code() != Status::Code::kCorruptFrame)
      fuzz::bug("unexpected status: " + status.message());
    fuzz::check_message(status.message(), path + " (frame 7)");
  }
  return 0;
}
