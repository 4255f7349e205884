/// @file reconstruction_config.h
/// @brief The sections of the configuration that fusion reads: preprocessing, the volume,
/// tracking and relocalisation.
#pragma once

#include "fusion/preprocess/preprocess_config.h"
#include "fusion/tracking/relocalisation_config.h"
#include "fusion/tracking/tracking_config.h"
#include "fusion/tsdf/tsdf_config.h"

namespace aoscan {

/// What Reconstruction needs of the configuration (pipeline/config.h's Config is one).
struct ReconstructionConfig {
  PreprocessConfig preprocess;
  FusionConfig fusion;
  TrackingConfig tracking;
  RelocalisationConfig relocalisation;
};

}  // namespace aoscan
