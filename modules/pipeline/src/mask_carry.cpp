// SPDX-License-Identifier: BSD-3-Clause
// Masks of an earlier frame carried into the current one by the camera's motion (the
// frames between the network's runs: thesis §6.1's "only when possible").
#include <cuefusion/common/exceptions.h>
#include <cuefusion/common/parallel.h>
#include <cuefusion/common/sensor_defaults.h>
#include <cuefusion/pipeline/mask_carry.h>

#include <cmath>
#include <cstdint>

namespace cuefusion
{
namespace pipeline
{
namespace
{
inline bool
hasDepth (float d)
{
  return d > 0.f && std::isfinite (d);
}
}  // namespace

std::vector<Instance>
carryMasks (const std::vector<Instance>& instances, const MaskView& from, const MaskView& to)
{
  for (const MaskView* view : {&from, &to})
    if (view->depth.type () != CV_32F || view->depth.cols != view->camera.width || view->depth.rows != view->camera.height)
      throw Error ("carryMasks", "a view's depth must be CV_32F of its camera's size");
  if (instances.empty ())
    return {};
  const cv::Mat ids = instancesToIdImage (instances, from.depth.size ());  // CV_16U, id = index + 1
  // A point of `to` in `from`'s camera: (from⁻¹ · to) · p, in float per pixel.
  const Eigen::Isometry3f to_from = (from.pose.inverse () * to.pose).cast<float> ();
  cv::Mat carried (to.depth.size (), CV_16U, cv::Scalar (0));
  parallelFor (to.depth.rows, [&] (int v) {
    const float* depth = to.depth.ptr<float> (v);
    std::uint16_t* out = carried.ptr<std::uint16_t> (v);
    for (int u = 0; u < to.depth.cols; ++u)
    {
      if (!hasDepth (depth[u]))
        continue;
      const Eigen::Vector3f p = to_from * to.camera.backProject (static_cast<float> (u), static_cast<float> (v), depth[u]);
      int us, vs;
      if (!from.camera.projectToPixel (p, us, vs))
        continue;
      const float seen = from.depth.at<float> (vs, us);
      // The same surface when within the jump that parts two surfaces anywhere else in the
      // project; else `from` saw something else there (the motion uncovered this point).
      if (hasDepth (seen) && std::abs (p.z () - seen) <= kSurfaceDepthJump * seen)
        out[u] = ids.at<std::uint16_t> (vs, us);
    }
  });
  std::vector<Instance> out;
  for (std::size_t i = 0; i < instances.size (); ++i)
  {
    // A new image: assigning the comparison to the copy's mask would write into the
    // caller's (cv::Mat shares its data; a source keeps the masks it hands out again).
    cv::Mat mask = carried == static_cast<int> (i + 1);
    if (cv::countNonZero (mask) == 0)
      continue;
    Instance instance = instances[i];
    instance.mask = mask;
    out.push_back (std::move (instance));
  }
  return out;
}
}  // namespace pipeline
}  // namespace cuefusion
