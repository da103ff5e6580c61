// SPDX-License-Identifier: BSD-3-Clause
#pragma once

#include <cuefusion/segmentation/organized_input.h>

#include <pcl/point_cloud.h>
#include <pcl/point_types.h>

#include <memory>

namespace cuefusion
{
namespace segmentation
{
/** \brief Parameters of DepthDiscontinuityEdgeEstimation (§4.2.1.1). */
struct DepthDiscontinuityEdgeEstimationConfig
{
  float noise_factor = 1.f;   ///< k: edge where Γ(u) > k·σ_d(u) (the reference thresholds at σ_d)
  int neighbour_step = 1;     ///< pixels between u and its 8 neighbours
  void validate () const;
};
/// The name before 0.2 (one config per class, named after it).
using DepthDiscontinuityEdgeConfig [[deprecated ("renamed DepthDiscontinuityEdgeEstimationConfig")]] = DepthDiscontinuityEdgeEstimationConfig;

/** \brief The geometry-aware (depth discontinuity) edge map of §4.2.1.1.
  *
  * Γ(u) = max over the 8 neighbours of |(v(u_i) − v(u))·n(u)|: how far a neighbour lies off
  * the tangent plane at u. Sensor noise grows with depth and viewing angle, so the
  * threshold is per pixel: u is an edge where Γ(u) > k·σ_d(u), σ_d the Nguyen et al. 2012
  * axial noise model (kinectAxialNoise) at the depth of u and the angle between its
  * viewing ray and n(u). A neighbour without a finite point (a hole or the shadow of an
  * occluding edge) makes u an edge, and so does a finite point without a finite normal;
  * pixels without a finite point get no value (Γ = NaN, not an edge).
  */
template <typename PointT, typename PointNT>
class DepthDiscontinuityEdgeEstimation : public OrganizedCloudWithNormals<PointT, PointNT, DepthDiscontinuityEdgeEstimationConfig>
{
public:
  using Ptr = std::shared_ptr<DepthDiscontinuityEdgeEstimation>;
  using ConstPtr = std::shared_ptr<const DepthDiscontinuityEdgeEstimation>;

  explicit DepthDiscontinuityEdgeEstimation (const DepthDiscontinuityEdgeEstimationConfig& config = DepthDiscontinuityEdgeEstimationConfig ())
  {
    this->setConfig (config);
  }

  void setNoiseFactor (float k) { this->updateConfig ([=] (DepthDiscontinuityEdgeEstimationConfig& c) { c.noise_factor = k; }); }
  float getNoiseFactor () const { return this->config_.noise_factor; }
  void setNeighbourStep (int step) { this->updateConfig ([=] (DepthDiscontinuityEdgeEstimationConfig& c) { c.neighbour_step = step; }); }
  int getNeighbourStep () const { return this->config_.neighbour_step; }

  /** \brief Organized edge map of the input's size (label 1 = depth edge), and the raw Γ
    * values (metres; +inf next to a missing neighbour) in \a gamma when given. With
    * indices (setIndices) the other points count as missing: label 0, Γ NaN, and the
    * points next to them are edges, as next to a hole. Throws cuefusion::Error on
    * unorganized, empty or all-NaN input, normals of another size and an index outside
    * the cloud.
    */
  void compute (pcl::PointCloud<pcl::Label>& edges, pcl::PointCloud<pcl::Intensity>* gamma = nullptr);
};
}  // namespace segmentation
}  // namespace cuefusion

#ifdef PCL_NO_PRECOMPILE
#include <cuefusion/segmentation/impl/depth_discontinuity_edge_estimation.hpp>
#endif
