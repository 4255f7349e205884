/// @file colour_image.cpp
/// @brief Colour images through OpenCV's imgcodecs; PNG writing through write_png().
#include "io/colour_image.h"

#include <algorithm>
#include <fstream>
#include <iterator>
#include <vector>

#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "io/png_write.h"

namespace aoscan {
namespace {

/// The 8-bit value nearest a 16-bit one.
std::uint8_t to_8bit(std::uint16_t v) {
  return static_cast<std::uint8_t>((static_cast<unsigned>(v) * 255u + 32767u) / 65535u);
}

template <typename T>
std::uint8_t channel(T v) {
  if constexpr (sizeof(T) == 1)
    return v;
  else
    return to_8bit(v);
}

/// `image` (1, 3 or 4 channels of T, OpenCV's BGR order) into `out` as RGB.
template <typename T>
void convert(const cv::Mat& image, Image<Rgb8>& out) {
  const int channels = image.channels();
  out.resize(image.cols, image.rows);
  for (int y = 0; y < image.rows; ++y) {
    const T* row = image.ptr<T>(y);
    for (int x = 0; x < image.cols; ++x) {
      const T* p = row + static_cast<std::ptrdiff_t>(x) * channels;
      Rgb8& o = out(x, y);
      if (channels == 1) {
        o.r = o.g = o.b = channel(p[0]);
      } else {
        o.r = channel(p[2]);
        o.g = channel(p[1]);
        o.b = channel(p[0]);
      }
    }
  }
}

/// The size a JPEG (its first SOF segment) or PNG (its IHDR) says it has, read from its header;
/// false when the bytes are neither, or the header is cut short.
bool declared_size(const std::uint8_t* b, std::size_t n, std::uint32_t& width,
                   std::uint32_t& height) {
  static const std::uint8_t kPng[8] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'};
  const auto be32 = [b](std::size_t at) {
    return std::uint32_t{b[at]} << 24 | std::uint32_t{b[at + 1]} << 16 |
           std::uint32_t{b[at + 2]} << 8 | b[at + 3];
  };
  if (n >= 24 && std::equal(kPng, kPng + 8, b) && std::equal(b + 12, b + 16, "IHDR")) {
    width = be32(16);
    height = be32(20);
    return true;
  }
  if (n < 4 || b[0] != 0xff || b[1] != 0xd8) return false;
  // JPEG: markers (0xff, fill bytes 0xff, a code) with a 16-bit length after all but the
  // standalone ones, up to the first start of frame (SOF0-15 but DHT, JPG and DAC). Bytes
  // between a segment and the next marker are skipped, as libjpeg does (with a warning).
  std::size_t i = 2;
  while (i + 1 < n) {
    while (i < n && b[i] != 0xff) ++i;
    while (i + 1 < n && b[i + 1] == 0xff) ++i;
    if (i + 1 >= n) return false;
    const std::uint8_t code = b[i + 1];
    i += 2;
    if (code == 0x01 || (code >= 0xd0 && code <= 0xd8)) continue;  // no length
    if (code == 0xd9 || code == 0xda || i + 2 > n) return false;    // no frame before the scan
    const std::size_t length = std::size_t{b[i]} << 8 | b[i + 1];
    if (code >= 0xc0 && code <= 0xcf && code != 0xc4 && code != 0xc8 && code != 0xcc) {
      if (length < 7 || i + 7 > n) return false;
      height = std::uint32_t{b[i + 3]} << 8 | b[i + 4];
      width = std::uint32_t{b[i + 5]} << 8 | b[i + 6];
      return true;
    }
    if (length < 2) return false;
    i += length;
  }
  return false;
}

Status size_differs(const std::string& where, std::uint64_t width, std::uint64_t height,
                    const ExpectedSize& expected) {
  return Status::corrupt_frame(where + ": size " + std::to_string(width) + "x" +
                               std::to_string(height) + " differs from " +
                               size_text(expected.width, expected.height) +
                               " of the colour camera");
}

}  // namespace

Status decode_colour_image(const std::uint8_t* bytes, std::size_t size, Image<Rgb8>& out,
                           const std::string& where, std::optional<ExpectedSize> expected) {
  try {
    if (bytes == nullptr || size == 0) return Status::corrupt_frame(where + ": empty colour image");
    // Refused before the codec sees it: a few hundred bytes of JPEG may declare up to 2^30
    // pixels (OpenCV's own limit), which its decoder allocates and fills in for a broken file.
    std::uint32_t width = 0, height = 0;
    if (!declared_size(bytes, size, width, height))
      return Status::corrupt_frame(where + ": not a JPEG or PNG colour image that can be decoded");
    if (std::uint64_t{width} * height > kMaxColourImagePixels)
      return Status::corrupt_frame(where + ": declares " + std::to_string(width) + " x " +
                                   std::to_string(height) + " pixels, more than the " +
                                   std::to_string(kMaxColourImagePixels) + " a colour image may have");
    // A frame of another size than its camera's is of no use: refused unread as well.
    if (expected && (width != static_cast<std::uint32_t>(expected->width) ||
                     height != static_cast<std::uint32_t>(expected->height)))
      return size_differs(where, width, height, *expected);
    const cv::Mat encoded(1, static_cast<int>(std::min<std::size_t>(size, 0x7fffffff)), CV_8UC1,
                          const_cast<std::uint8_t*>(bytes));
    const cv::Mat image = cv::imdecode(encoded, cv::IMREAD_UNCHANGED);
    if (image.empty())
      return Status::corrupt_frame(where + ": not a colour image that can be decoded (JPEG, PNG)");
    const int channels = image.channels();
    if (channels != 1 && channels != 3 && channels != 4)
      return Status::corrupt_frame(where + ": " + std::to_string(channels) +
                                   " channels (grey, RGB or RGBA expected)");
    if (image.depth() == CV_8U)
      convert<std::uint8_t>(image, out);
    else if (image.depth() == CV_16U)
      convert<std::uint16_t>(image, out);
    else
      return Status::corrupt_frame(where + ": pixels are neither 8- nor 16-bit integers");
    // The header's size is the decoded one for PNG and JPEG; checked, not assumed.
    if (expected && (out.width() != expected->width || out.height() != expected->height))
      return size_differs(where, static_cast<std::uint64_t>(out.width()),
                          static_cast<std::uint64_t>(out.height()), *expected);
    return Status::ok();
  } catch (const std::exception& e) {
    return Status::corrupt_frame(where + ": " + e.what());
  }
}

Status read_colour_image(const std::string& path, Image<Rgb8>& out,
                         std::optional<std::uint64_t> frame_index,
                         std::optional<ExpectedSize> expected) {
  const std::string where =
      frame_index ? path + " (frame " + std::to_string(*frame_index) + ")" : path;
  try {
    std::ifstream in(path, std::ios::binary);
    if (!in) return Status::corrupt_frame(where + ": cannot open colour image");
    thread_local std::vector<unsigned char> bytes;
    bytes.assign(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
    if (in.bad()) return Status::corrupt_frame(where + ": cannot read colour image");
    return decode_colour_image(bytes.data(), bytes.size(), out, where, expected);
  } catch (const std::exception& e) {
    return Status::corrupt_frame(where + ": " + e.what());
  }
}

void write_colour_png(const std::string& path, const Image<Rgb8>& image) {
  static_assert(sizeof(Rgb8) == 3, "Rgb8 rows are PNG's RGB rows");
  write_png(path, image.width(), image.height(), PngFormat::kRgb8,
            [&image](int y) -> const void* { return image.row(y); });
}

void encode_colour_jpeg(const Image<Rgb8>& image, int quality, std::vector<std::uint8_t>& out) {
  if (image.width() <= 0 || image.height() <= 0)
    throw Error(ExitCode::kFailure, "JPEG encoding: empty image");
  // OpenCV's codecs take BGR rows; the image's rows are RGB (and contiguous).
  const cv::Mat rgb(image.height(), image.width(), CV_8UC3,
                    const_cast<Rgb8*>(image.row(0)));
  thread_local cv::Mat bgr;
  cv::cvtColor(rgb, bgr, cv::COLOR_RGB2BGR);
  const std::vector<int> params = {cv::IMWRITE_JPEG_QUALITY, std::clamp(quality, 1, 100)};
  out.clear();
  if (!cv::imencode(".jpg", bgr, out, params))
    throw Error(ExitCode::kFailure, "JPEG encoding failed");
}

}  // namespace aoscan
