// SPDX-License-Identifier: BSD-3-Clause
#pragma once

#include <opencv2/core.hpp>

namespace cuefusion
{
namespace reconstruction
{
/** \brief How noisy a depth image is, measured against the Kinect model every noise
  * threshold of cuefusion is written in (KinectNoiseModel, σ_z(z) at normal incidence).
  */
struct DepthNoiseEstimate
{
  /** Median over the image's patches of (measured σ_z) / σ_z(z) of the model: about 1 for
    * Kinect-class structured light, about 2 for an active-stereo camera (noise growing with
    * z²) beyond a metre, below 1 for a quantised or smoothed sensor (its residuals are
    * steps, not noise) and for exact depth; 0 when no patch could be measured.
    */
  float ratio = 0.f;
  int patches = 0;  ///< patches measured
};

/** \brief Measures the depth noise of \a depth (CV_32F metres, 0 or NaN = invalid) on
  * square patches of \a patch_size pixels (a grid, not overlapping): in each patch with at
  * least three quarters of its pixels valid, a plane is fitted to inverse depth (a plane
  * of the scene is one in inverse depth, whatever its tilt) and the RMS of the residuals,
  * taken back to depth (σ_z = σ_{1/z} · z²), is divided by the model's σ_z at the patch's
  * mean depth. Patches across an edge or on a curved surface read high, so the median of
  * the patches' ratios is reported: it holds while fewer than half the patches do.
  * Throws cuefusion::Error on another type than CV_32F or a patch size below 3.
  */
DepthNoiseEstimate
estimateDepthNoise (const cv::Mat& depth, int patch_size = 8);
}  // namespace reconstruction
}  // namespace cuefusion
