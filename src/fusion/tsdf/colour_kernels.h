/// @file colour_kernels.h
/// @brief Internal to the colour integration: what its portable code (colour_volume.cpp) and its
/// AVX2 kernels (colour_volume_avx2.cpp) share. Not for use outside src/fusion/tsdf/.
#pragma once

#include <cstdint>

#if defined(__x86_64__) && defined(__GNUC__)
#define AOSCAN_COLOUR_X86 1
#else
#define AOSCAN_COLOUR_X86 0
#endif

namespace aoscan {
namespace detail {

/// A frame's depth camera as the colour integration projects voxels into it.
struct ColourProjection {
  float R[3][3], t[3];  ///< camera from world
  float fx, fy;
  float cx, cy;  ///< the principal point plus half a pixel: floor(u) is the voxel's pixel
  float voxel_m;
  int width, height;
  const float* depth;  ///< the depth image (m), rows of `width`
  float band_m;        ///< |depth - z| at most this
};

/// The shell voxels of one block that the frame saw: their voxel index in the block, their depth
/// pixel (y * width + x) and their camera-frame position.
struct ColourHits {
  int count = 0;
  std::uint16_t voxel[512];
  int pixel[512];
  float x[512], y[512], z[512];
};

/// Projects the `n` voxels `voxel[0..n)` of the block whose first voxel has global coordinates
/// `origin` into the depth frame and keeps in `hits` those with a depth within band_m of their
/// z, in their order. A voxel's centre is (origin + local) * voxel_m; its camera-frame position
/// ((R0 * x + R1 * y) + R2 * z) + t; its pixel floor(fx * x / z + cx), floor(fy * y / z + cy) with
/// z > 0 inside the image: these operations in this order, no fused multiply-adds.
void project_shell_portable(const ColourProjection& c, const int origin[3],
                            const std::uint16_t* voxel, int n, ColourHits& hits);

/// The running mean of `n` colour voxels (r, g, b, weight; 4 bytes each, at `voxels` + 4 *
/// index[k]) with the samples r[k], g[k], b[k]: each channel (c * w + s) / (w + 1) rounded to the
/// nearest byte (ties to even), the weight w + 1 capped at `cap`.
void update_colours_portable(std::uint8_t* voxels, const std::uint16_t* index, const float* r,
                             const float* g, const float* b, int n, float cap);

#if AOSCAN_COLOUR_X86
/// project_shell_portable() eight voxels per AVX2 vector, with a gather of their depths: the same
/// operations in the same order, so the same hits bit for bit. Only on a CPU with AVX2.
void project_shell_avx2(const ColourProjection& c, const int origin[3],
                        const std::uint16_t* voxel, int n, ColourHits& hits);

/// update_colours_portable() eight voxels per AVX2 vector: the same operations, the same bytes.
/// Only on a CPU with AVX2.
void update_colours_avx2(std::uint8_t* voxels, const std::uint16_t* index, const float* r,
                         const float* g, const float* b, int n, float cap);
#endif

}  // namespace detail
}  // namespace aoscan
