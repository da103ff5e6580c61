// SPDX-License-Identifier: BSD-3-Clause
// Parameter checks of the segmentation configs: one ParameterError naming the config field
// (apps/cuefusion/main.cpp maps fields to the options that set them); the noise scale a
// GeometricSegmentationConfig stands for.
#include <cuefusion/common/exceptions.h>
#include <cuefusion/reconstruction/noise_estimation.h>
#include <cuefusion/segmentation/geometric_segmentation.h>
#include <cuefusion/segmentation/support_plane_removal.h>
#include <cuefusion/segmentation/surface_preprocessing.h>

#include <algorithm>
#include <cmath>

namespace cuefusion
{
namespace segmentation
{
namespace
{
void
require (bool ok, const char* parameter, const char* what)
{
  if (!ok)
    throw ParameterError (parameter, what);
}
}  // namespace

void
ConcavityEdgeEstimationConfig::validate () const
{
  require (std::isfinite (threshold) && threshold > -1.f && threshold <= 1.f, "ConcavityEdgeEstimationConfig::threshold",
           "must lie in (-1, 1] (it compares a cosine)");
  require (neighbour_step >= 1 && neighbour_step <= 16, "ConcavityEdgeEstimationConfig::neighbour_step", "must be 1..16 pixels");
  require (std::isfinite (noise_slope) && noise_slope >= 0.f && noise_slope <= 1000.f, "ConcavityEdgeEstimationConfig::noise_slope",
           "must lie in [0, 1000]");
  require (wide_step >= 0 && wide_step <= 16, "ConcavityEdgeEstimationConfig::wide_step", "must be 0..16 pixels (0: no wide test)");
  require (std::isfinite (wide_noise_slope) && wide_noise_slope >= 0.f && wide_noise_slope <= 1000.f,
           "ConcavityEdgeEstimationConfig::wide_noise_slope", "must lie in [0, 1000]");
  require (std::isfinite (wide_noise_scale) && wide_noise_scale > 0.f && wide_noise_scale <= 100.f,
           "ConcavityEdgeEstimationConfig::wide_noise_scale", "must lie in (0, 100] (a sensor's noise over the Kinect's)");
}

void
DepthDiscontinuityEdgeEstimationConfig::validate () const
{
  require (std::isfinite (noise_factor) && noise_factor > 0.f, "DepthDiscontinuityEdgeEstimationConfig::noise_factor", "must be positive");
  require (neighbour_step >= 1 && neighbour_step <= 16, "DepthDiscontinuityEdgeEstimationConfig::neighbour_step", "must be 1..16 pixels");
}

void
EdgeLabelingConfig::validate () const
{
  require (closing_iterations >= 0 && closing_iterations <= 16, "EdgeLabelingConfig::closing_iterations", "must be 0..16");
  require (min_segment_size >= 1, "EdgeLabelingConfig::min_segment_size", "must be at least 1 pixel");
  require (edge_assignment_radius >= 0 && edge_assignment_radius <= 64, "EdgeLabelingConfig::edge_assignment_radius", "must be 0..64 pixels");
  require (std::isfinite (max_depth_jump) && max_depth_jump > 0.f, "EdgeLabelingConfig::max_depth_jump", "must be positive");
}

void
GeometricSegmentationConfig::validate () const
{
  if (preprocess)
    preprocessing.validate ();
  concavity.validate ();
  discontinuity.validate ();
  labeling.validate ();
  require (std::isfinite (noise_scale) && noise_scale >= 0.f && noise_scale <= 100.f, "GeometricSegmentationConfig::noise_scale",
           "must lie in [0, 100] (0 = measured from the depth)");
}

GeometricSegmentationConfig
GeometricSegmentationConfig::noiseScaled (float scale) const
{
  GeometricSegmentationConfig out = *this;
  out.preprocessing.bilateral.noise_range_sigma *= scale;
  out.concavity.noise_slope *= scale;
  out.concavity.wide_noise_slope *= scale;
  out.concavity.wide_noise_scale *= scale;
  out.discontinuity.noise_factor *= scale;
  return out;
}

float
resolveNoiseScale (const GeometricSegmentationConfig& config, const cv::Mat& raw_depth)
{
  return config.measuresNoise () ? config.scaleFor (measureNoiseRatio (raw_depth)) : config.scaleFor (0.f);
}

float
measureNoiseRatio (const cv::Mat& raw_depth)
{
  return reconstruction::estimateDepthNoise (raw_depth).ratio;
}

void
SurfacePreprocessingConfig::validate () const
{
  bilateral.validate ("SurfacePreprocessingConfig::bilateral");
  require (!bilateral.enabled || bilateral.noise_range_sigma > 0.0, "SurfacePreprocessingConfig::bilateral.noise_range_sigma",
           "must lie in (0, 100] noise units: the segmentation's smoothing follows the sensor noise");
  normals.validate ("SurfacePreprocessingConfig::normals");
  require (std::isfinite (integral_smoothing) && integral_smoothing >= 1.f, "SurfacePreprocessingConfig::integral_smoothing", "must be at least 1");
  require (max_hole_pixels >= 0 && max_hole_pixels <= 1024, "SurfacePreprocessingConfig::max_hole_pixels", "must lie in [0, 1024] (0: off)");
}

void
SupportPlaneRemovalConfig::validate () const
{
  require (std::isfinite (distance_threshold) && distance_threshold > 0.f, "SupportPlaneRemovalConfig::distance_threshold", "must be positive");
  require (max_iterations >= 1, "SupportPlaneRemovalConfig::max_iterations", "must be at least 1");
  require (sample_step >= 1, "SupportPlaneRemovalConfig::sample_step", "must be at least 1");
  require (min_plane_fraction >= 0.f && min_plane_fraction <= 1.f, "SupportPlaneRemovalConfig::min_plane_fraction", "must lie in [0, 1]");
  require (min_segment_inlier_fraction > 0.f && min_segment_inlier_fraction <= 1.f, "SupportPlaneRemovalConfig::min_segment_inlier_fraction",
           "must lie in (0, 1]");
  require (max_normal_angle_deg >= 0.f && max_normal_angle_deg <= 90.f, "SupportPlaneRemovalConfig::max_normal_angle_deg", "must be 0..90 degrees");
}
}  // namespace segmentation
}  // namespace cuefusion
