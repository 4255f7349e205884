/// @file colour_image.h
/// @brief Colour images of recordings (JPEG and PNG, through OpenCV's image codecs) as 8-bit
/// RGB, and the lossless PNG that `record` writes.
#pragma once

#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "core/colour.h"
#include "core/image.h"
#include "core/status.h"

namespace aoscan {

/// The most pixels a colour image may have: 2^25 (33.5 M, 8192 x 4096; the colour cameras of
/// depth sensors give up to 4096 x 3072). A file that declares more is refused unread.
inline constexpr std::uint64_t kMaxColourImagePixels = std::uint64_t{1} << 25;

/// The size a colour image must have, when its reader knows it (its colour camera's): an image
/// whose header declares another size is refused before it is decoded.
struct ExpectedSize {
  int width = 0;
  int height = 0;
};

/// Decodes the image at `path` into `out` as 8-bit RGB, reusing `out`'s allocation (safe to call
/// from several threads). 8-bit grey is repeated in the three channels; 16-bit images keep
/// round(v / 257) (the nearest 8-bit value); an alpha channel is dropped. Returns ok, or
/// corrupt_frame with one line "PATH: reason" (or "PATH (frame N): reason") for a missing or
/// unreadable file, bytes that are not a JPEG or PNG (by their header) or that the codec does not
/// decode, a header declaring more than kMaxColourImagePixels or (given `expected`) another size
/// than expected ("size WxH differs from WxH of the colour camera"), or a pixel type that is not
/// 8- or 16-bit integer.
/// On failure `out`'s content is unspecified. Never throws.
Status read_colour_image(const std::string& path, Image<Rgb8>& out,
                         std::optional<std::uint64_t> frame_index = std::nullopt,
                         std::optional<ExpectedSize> expected = std::nullopt);

/// Decodes an encoded image held in memory (`size` bytes at `bytes`: a JPEG frame of a camera's
/// MJPEG stream, a PNG, ...) into `out` as read_colour_image() does. Returns ok, or corrupt_frame
/// "`where`: reason" for bytes no codec decodes, another size than `expected` or an unusable
/// pixel type. Never throws.
Status decode_colour_image(const std::uint8_t* bytes, std::size_t size, Image<Rgb8>& out,
                           const std::string& where,
                           std::optional<ExpectedSize> expected = std::nullopt);

/// Writes `image` as an 8-bit RGB PNG at `path` itself (wrap it in write_atomically() for an
/// output). Throws like write_png().
void write_colour_png(const std::string& path, const Image<Rgb8>& image);

/// `image` encoded as a baseline JPEG of `quality` (1-100) into `out` (its allocation reused), for
/// the service's live stream. Throws Error(kFailure) when the image is empty or the codec fails.
void encode_colour_jpeg(const Image<Rgb8>& image, int quality, std::vector<std::uint8_t>& out);

}  // namespace aoscan
