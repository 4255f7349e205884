/// @file pyramid.h
/// @brief The tracking pyramid (KinectFusion): level 0 is the filtered depth, every coarser level
/// halves the one before, each with its vertex and normal maps.
#pragma once

#include "core/image.h"
#include "core/intrinsics.h"
#include "fusion/preprocess/preprocess_config.h"
#include "geometry/point_maps.h"

namespace aoscan {

/// Builds the tracking pyramid from a (bilateral-)filtered metric depth image of `intrinsics`'
/// resolution: level 0 is `filtered_m`, level l + 1 is downsample_depth() of level l with
/// config.pyramid_max_depth_diff_m; every level gets Intrinsics::scaled(l), its vertex map and its
/// normal map (jump threshold config.normal_max_depth_jump_m * 2^l) through compute_point_maps().
/// Throws input_error when the image size differs from intrinsics.width x intrinsics.height.
void build_pyramid(const Image<float>& filtered_m, const Intrinsics& intrinsics,
                   const PreprocessConfig& config, DepthPyramid& out);

/// build_pyramid() with the default PreprocessConfig thresholds.
void build_pyramid(const Image<float>& filtered_m, const Intrinsics& intrinsics, DepthPyramid& out);

}  // namespace aoscan
