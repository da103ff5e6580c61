// SPDX-License-Identifier: BSD-3-Clause
#pragma once

namespace cuefusion
{
/** \name What a Kinect-class RGB-D sensor gives, as the defaults several modules share
  * Each is written once here; the Config fields that expose them default to these, and
  * test/lint/thresholds.py fails when a threshold is written as a literal in two files.
  * \{ */

/** Depths outside [kMinDepth, kMaxDepth] metres are not used (preprocessing, the TSDF,
  * the keyframes' fern tests): a Kinect-class sensor's working range, beyond which its
  * depth noise (σ_z ≈ 0.04 m at 5 m) is larger than the objects' parts. */
constexpr double kMinDepth = 0.1;
constexpr double kMaxDepth = 5.0;

/** Neighbouring depths within this share of the depth of each other lie on one surface
  * (2 %): the segmentation's edge labelling, normals and instance merging, and the TSDF
  * integration's bilinear depth. Kinect's disparity step at 4 m is about 1.3 % of the
  * depth, so one quantisation step never reads as a jump. */
constexpr float kSurfaceDepthJump = 0.02f;

/** The coarser rule of tracking's pyramid (2×2 block averages, ±1 px normals): 5 %. */
constexpr double kPyramidDepthJump = 0.05;

/** Frames per second of a sequence without timestamps, and of the generated ones. */
constexpr double kFrameRate = 30.0;
/** \} */
}  // namespace cuefusion
