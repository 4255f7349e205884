/// @file preprocess_reference.h
/// @brief Test oracles of the preprocess module: plain per-pixel scalar versions of the
/// border-outlier removal and of the bilateral filter, which the fast paths are checked against.
#pragma once

#include "core/image.h"
#include "fusion/preprocess/preprocess_config.h"

namespace aoscan {

/// Plain per-pixel scalar reference of remove_border_outliers() (same contract; the fast version
/// equals it bit for bit).
void remove_border_outliers_reference(const Image<float>& depth_m, float threshold_m,
                                      float threshold_per_m2, Image<float>& out);

/// Plain per-pixel scalar reference of bilateral_filter() (std::exp for every tap; the fast
/// versions agree with it within 1e-6 m).
void bilateral_filter_reference(const Image<float>& depth_m, const PreprocessConfig& config,
                                Image<float>& out);

}  // namespace aoscan
