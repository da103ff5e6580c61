// SPDX-License-Identifier: BSD-3-Clause
#pragma once

#include <cuefusion/segmentation/organized_input.h>

#include <pcl/point_cloud.h>
#include <pcl/point_types.h>

#include <algorithm>
#include <cmath>
#include <memory>

namespace cuefusion
{
namespace segmentation
{
/** \brief When a neighbour counts as convex in ConcavityEdgeEstimation. */
enum class ConvexityTest
{
  TangentPlane,     ///< §4.2.1.1: (v(u_i) − v(u))·n(u) < 0
  NormalDivergence  ///< (n(u_i) − n(u))·(v(u_i) − v(u)) ≥ 0, robust to smoothed normals (see concavityTermSymmetric)
};

/** \brief Parameters of ConcavityEdgeEstimation (§4.2.1.1). */
struct ConcavityEdgeEstimationConfig
{
  ConvexityTest convexity_test = ConvexityTest::NormalDivergence;
  float threshold = 0.991f;   ///< edge where Φ(u) < threshold (the reference's value)
  int neighbour_step = 1;     ///< pixels between u and its 8 neighbours; larger for noisy far-range data
  /** Where the normals' noise exceeds the threshold, it gives way: the edge test is
    * Φ < min(threshold, cos θ(z)) with θ(z) = noise_slope · σ_z(z) / z radians (σ_z the
    * Kinect axial noise at normal incidence; cos to second order). The normals'
    * angular noise grows like σ_z/z (depth noise over the pixel spacing); at the
    * default it takes over from the reference's 0.991 (7.7°) beyond about 1.2 m and is
    * 18° at 3 m, where noise made far walls all edges. 0 = the fixed threshold alone.
    */
  float noise_slope = 65.f;
  /** Far creases. Normals by central differences over ±s pixels (the segmentation's s = 4)
    * turn across a crease over the 2s pixels their differences span, so neighbouring
    * normals differ by a right angle's 90°/(2s) per pixel (11° at s = 4). Where θ(z)
    * exceeds that (beyond about 2.1 m on Kinect noise, nearer on a noisier sensor) Φ
    * cannot see a wall meeting the floor. There the wide test compares the normals at
    * u − s·d and u + s·d (d: across, down and the two diagonals), whose differences share
    * no pixel: Φ_w,d(u) = 1 where they are convex (the convexity test below), else their
    * dot product, and u is an edge where Φ_w,d < cos θ_w(z), θ_w(z) = wide_noise_slope ·
    * σ_z(z) / z, and Φ_w,d(u) is no larger than at u ∓ d (a crease line one or two pixels
    * wide, not the 2s-pixel band the pairs straddle). A pair counts only on one continuous
    * surface (its depths within what a surface 75° from the view spans) and between two
    * surfaces that stay flat 2s pixels further out (the normals at u ∓ 3s·d agree with
    * those at u ∓ s·d within θ_w): walls, floors and furniture, not the faces of a small
    * far object, which the wide pairs cut into pieces the masks did not unite (far
    * clutter lost 0.15 mean object IoU without that rule). The span s = wide_step
    * pixels; 0 = no wide test. */
  int wide_step = 4;
  /** The wide test's noise, measured: on a room's corner (floor and wall) seen from 1–5 m,
    * 0–50° off the wall's normal, Kinect noise, 24 views drawn at random, the smallest
    * slope at which the wide test marks no more of the flat surface than Φ alone (median
    * excess 0.01 %, at most 0.04 %; 100 marked 0.4–0.8 % more, 140 0.06 %), and every view's
    * floor and wall come out apart (Φ alone leaves most views beyond 3 m one segment);
    * test ConcavityEdgeEstimation.AFarCreaseIsFoundAndAFarWallIsNot on another draw. */
  float wide_noise_slope = 160.f;
  /** The wide test on a noisier sensor than the Kinect its slope was measured on: the pairs
    * span wideSpan () = round(wide_step × wide_noise_scale) pixels instead of wide_step,
    * with normals by central differences over that span (not the segmentation's own), and
    * θ_w(z) shrinks by wide_step / wideSpan (). A normal's angular noise is the depth
    * noise over the span of its differences, so the test keeps the noise it was measured
    * at: on the RealSense-like model (noise 1.97 × the Kinect's) θ_w reached 86° at 3 m and
    * a floor meeting a wall was found only in pieces beyond 2 m — every room's floor and
    * walls one segment. GeometricSegmentationConfig::noiseScaled sets it to the measured
    * noise scale, so Kinect-like depth (scale below 1.125) keeps 4 px; set by hand it is a
    * sensor's noise over the Kinect's. */
  float wide_noise_scale = 1.f;
  /** \brief The wide test's span in pixels (see wide_noise_scale); 0 without the test. */
  int wideSpan () const { return wide_step > 0 ? std::max (1, static_cast<int> (std::lround (wide_step * wide_noise_scale))) : 0; }
  void validate () const;
};
/// The name before 0.2 (one config per class, named after it).
using ConcavityEdgeConfig [[deprecated ("renamed ConcavityEdgeEstimationConfig")]] = ConcavityEdgeEstimationConfig;

/** \brief The concavity-aware edge map of §4.2.1.1.
  *
  * Most objects are convex, so concave creases are where objects meet (a box on a table,
  * two boxes side by side). For each neighbour u_i of u:
  * Φ_i(u) = 1 if (v(u_i) − v(u))·n(u) < 0 (convex), else n(u)·n(u_i); Φ(u) = min_i Φ_i(u),
  * and u is an edge where Φ(u) < threshold. Normals must point towards the sensor (as PCL's
  * normal estimators orient them). Pixels without a finite point or normal get no value
  * (Φ = NaN, not an edge); neighbours without one are left out of the minimum.
  *
  * \code
  * ConcavityEdgeEstimation<pcl::PointXYZ, pcl::Normal> concavity;
  * concavity.setInputCloud (cloud);
  * concavity.setInputNormals (normals);
  * pcl::PointCloud<pcl::Label> edges;       // label 1 = edge, 0 = not
  * concavity.compute (edges);
  * \endcode
  */
template <typename PointT, typename PointNT>
class ConcavityEdgeEstimation : public OrganizedCloudWithNormals<PointT, PointNT, ConcavityEdgeEstimationConfig>
{
public:
  using Ptr = std::shared_ptr<ConcavityEdgeEstimation>;
  using ConstPtr = std::shared_ptr<const ConcavityEdgeEstimation>;

  explicit ConcavityEdgeEstimation (const ConcavityEdgeEstimationConfig& config = ConcavityEdgeEstimationConfig ()) { this->setConfig (config); }

  void setThreshold (float threshold) { this->updateConfig ([=] (ConcavityEdgeEstimationConfig& c) { c.threshold = threshold; }); }
  float getThreshold () const { return this->config_.threshold; }
  void setNeighbourStep (int step) { this->updateConfig ([=] (ConcavityEdgeEstimationConfig& c) { c.neighbour_step = step; }); }
  int getNeighbourStep () const { return this->config_.neighbour_step; }

  /** \brief Organized edge map of the input's size (label 1 = concave edge), and the raw
    * Φ values in \a phi when given. With indices (setIndices) the other points count as
    * missing: label 0, Φ NaN. Throws cuefusion::Error on unorganized, empty or all-NaN
    * input, normals of another size and an index outside the cloud.
    */
  void compute (pcl::PointCloud<pcl::Label>& edges, pcl::PointCloud<pcl::Intensity>* phi = nullptr);
};
}  // namespace segmentation
}  // namespace cuefusion

#ifdef PCL_NO_PRECOMPILE
#include <cuefusion/segmentation/impl/concavity_edge_estimation.hpp>
#endif
