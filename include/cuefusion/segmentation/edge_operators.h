// SPDX-License-Identifier: BSD-3-Clause
#pragma once

#include <cuefusion/common/pinhole_camera.h>

#include <Eigen/Core>

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>

namespace cuefusion
{
namespace segmentation
{
// Per-pixel math of §4.2.1.1, kept apart from the loops that drive it (DESIGN.md).

/** \brief Φ_i(u) of §4.2.1.1: 1 when neighbour \a vi lies behind the tangent plane of
  * (v, n) — a convex configuration, normals turned towards the camera — else n·n_i, which
  * is low across a concave crease.
  */
inline float
concavityTerm (const Eigen::Vector3f& v, const Eigen::Vector3f& n, const Eigen::Vector3f& vi,
               const Eigen::Vector3f& ni)
{
  // Both sides are computed so the compiler can select without a branch: on a noisy flat
  // surface the test is a coin toss and a branch would mispredict half the time.
  const float agreement = n.dot (ni);
  return (vi - v).dot (n) < 0.f ? 1.f : agreement;
}

/** \brief Φ_i(u) with a symmetric convexity test: convex when the normals turn away from
  * each other along the step, (n_i − n)·(v_i − v) ≥ 0 (the criterion of LCCP, Stein et
  * al. 2014), else n·n_i. Unlike the tangent-plane test it also holds where smoothed
  * normals round off a sharp convex edge: there v(u_i) can rise above the tilted tangent
  * plane at u although the surface is convex.
  */
inline float
concavityTermSymmetric (const Eigen::Vector3f& v, const Eigen::Vector3f& n, const Eigen::Vector3f& vi,
                        const Eigen::Vector3f& ni)
{
  const float agreement = n.dot (ni);  // computed unconditionally: see concavityTerm
  return (ni - n).dot (vi - v) >= 0.f ? 1.f : agreement;
}

/** \brief Γ_i(u) of §4.2.1.1: distance of neighbour \a vi from the tangent plane of (v, n). */
inline float
discontinuityTerm (const Eigen::Vector3f& v, const Eigen::Vector3f& n, const Eigen::Vector3f& vi)
{
  return std::abs ((vi - v).dot (n));
}

/** \brief σ_d(u): the Nguyen et al. 2012 axial noise at vertex \a v (camera frame) with
  * normal \a n; θ is the angle between the viewing ray and the normal.
  */
inline float
axialNoiseAt (const Eigen::Vector3f& v, const Eigen::Vector3f& n)
{
  const float cos_theta = std::min (1.f, std::abs (v.dot (n)) / v.norm ());
  return static_cast<float> (kinectAxialNoise (v.z (), std::acos (cos_theta)));
}

/** \brief Lower bound of σ_d at depth \a z (θ = 0): Γ at or below k times this is no edge,
  * whatever the viewing angle, so the acos of axialNoiseAt is needed only above it.
  */
inline float
axialNoiseLowerBound (float z)
{
  return KinectNoiseModel::atNormalIncidence (z);
}

/** \brief The angle (radians) by which depth noise turns the normals at depth \a z:
  * θ(z) = \a slope · σ_z(z) / z, σ_z at normal incidence. The one home of the formula
  * behind ConcavityEdgeEstimationConfig's noise_slope and wide_noise_slope.
  */
inline float
normalNoiseAngle (float z, float slope)
{
  return slope * axialNoiseLowerBound (z) / z;
}

/** \brief The depth-discontinuity decision of §4.2.1.1: Γ(u) > k·σ_d(u). */
inline bool
isDepthDiscontinuity (float gamma, float k, const Eigen::Vector3f& v, const Eigen::Vector3f& n)
{
  return gamma > k * axialNoiseLowerBound (v.z ()) && gamma > k * axialNoiseAt (v, n);
}

inline bool
isFiniteVector (const Eigen::Vector3f& v)
{
  return std::isfinite (v.x ()) && std::isfinite (v.y ()) && std::isfinite (v.z ());
}

}  // namespace segmentation
}  // namespace cuefusion
