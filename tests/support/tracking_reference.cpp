/// @file tracking_reference.cpp
/// @brief Plain single-threaded reference of the ICP normal equations.
#include "support/tracking_reference.h"

#include <algorithm>

#include "core/status.h"
#include "fusion/tracking/icp_kernels.h"

namespace aoscan {

IcpSystem icp_system_reference(const PointMaps& frame, const PointMaps& model,
                               const Pose& T_model_camera, const TrackingConfig& config,
                               int pixel_step) {
  if (frame.vertices.width() != frame.normals.width() ||
      frame.vertices.height() != frame.normals.height() ||
      model.vertices.width() != model.normals.width() ||
      model.vertices.height() != model.normals.height())
    throw usage_error("icp: vertex and normal maps differ in size");
  const int step = std::max(1, pixel_step);
  const icp_detail::Associator assoc(model, T_model_camera, config);
  icp_detail::Accumulator<double> total;
  for (int y = 0; y < frame.vertices.height(); ++y)
    for (int x = 0; x < frame.vertices.width(); ++x)
      if ((x - y % step) % step == 0)
        assoc.pixel(frame.vertices(x, y).data(), frame.normals(x, y).data(), total);
  return total.system();
}

}  // namespace aoscan
