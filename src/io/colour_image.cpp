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

}  // namespace

Status decode_colour_image(const std::uint8_t* bytes, std::size_t size, Image<Rgb8>& out,
                           const std::string& where) {
  try {
    if (bytes == nullptr || size == 0) return Status::corrupt_frame(where + ": empty colour image");
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
    return Status::ok();
  } catch (const std::exception& e) {
    return Status::corrupt_frame(where + ": " + e.what());
  }
}

Status read_colour_image(const std::string& path, Image<Rgb8>& out,
                         std::optional<std::uint64_t> frame_index) {
  const std::string where =
      frame_index ? path + " (frame " + std::to_string(*frame_index) + ")" : path;
  try {
    std::ifstream in(path, std::ios::binary);
    if (!in) return Status::corrupt_frame(where + ": cannot open colour image");
    thread_local std::vector<unsigned char> bytes;
    bytes.assign(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
    if (in.bad()) return Status::corrupt_frame(where + ": cannot read colour image");
    return decode_colour_image(bytes.data(), bytes.size(), out, where);
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
