// SPDX-License-Identifier: BSD-3-Clause
#pragma once

#include <cuefusion/common/instance.h>
#include <cuefusion/common/pinhole_camera.h>

#include <Eigen/Geometry>
#include <opencv2/core.hpp>

#include <vector>

namespace cuefusion
{
namespace pipeline
{
/** \brief A frame as far as carrying masks goes: its depth (metres, CV_32F, 0 or NaN =
  * none), its camera and its camera-to-world pose. */
struct MaskView
{
  cv::Mat depth;
  PinholeCamera camera;
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity ();
};

/** \brief Masks computed on the view \a from, carried into the view \a to by the camera's
  * motion (a live camera's newest masks, or `--masks-every`'s reused ones, are an earlier
  * frame's): each pixel of \a to with depth is back-projected, moved into \a from and
  * looked up there; it keeps the instance found when \a from saw the same surface there
  * (its depth within kSurfaceDepthJump of the point's), and none where \a from saw
  * something nearer or farther (what the motion uncovered) or nothing. Pixels of \a to
  * without depth take none. Overlapping masks are resolved as instancesToIdImage does
  * (higher score on top). The instances keep their class and score, in their order;
  * those left without a pixel are dropped.
  */
std::vector<Instance>
carryMasks (const std::vector<Instance>& instances, const MaskView& from, const MaskView& to);
}  // namespace pipeline
}  // namespace cuefusion
