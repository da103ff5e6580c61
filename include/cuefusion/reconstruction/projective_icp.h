// SPDX-License-Identifier: BSD-3-Clause
#pragma once

#include <cuefusion/reconstruction/preprocessing.h>

#include <Eigen/Geometry>

#include <cstddef>
#include <vector>

namespace cuefusion
{
namespace reconstruction
{
/** \brief Projective point-to-plane ICP parameters (§4.1.3). */
struct ProjectiveICPConfig
{
  /** Iterations per pyramid level, finest level first (KinectFusion: 10, 5, 4). */
  std::vector<int> iterations{10, 5, 4};
  double max_distance = 0.05;           ///< correspondence rejection (metres)
  double max_angle_deg = 20.0;          ///< between the two normals, for frames at angle_reference_depth or nearer
  /** The normal gate follows the frame's normal noise: a normal from depth differences
    * over a fixed pixel step has an angular noise ∝ σ_z(z) / z (σ_z: KinectNoiseModel),
    * so for a frame whose median depth z lies beyond angle_reference_depth the gate is
    * max_angle_deg × (σ_z(z)/z) / (σ_z(z_ref)/z_ref), at most max_angle_limit_deg. At
    * 3 m that is 40° (a 20° gate took 83 % of a noisy 3 m view's points for outliers and
    * lost it from its second frame). 0 = a fixed max_angle_deg. */
  double angle_reference_depth = 1.5;
  /** The depth's noise as a multiple of the Kinect model's (the segmentation's noise
    * scale; FusionPipeline sets the measured one): the normals' angular noise grows with
    * it, and so does the gate, max_angle_deg × noise_scale × the depth's ratio above (at
    * angle_reference_depth or nearer, 1), between max_angle_deg and max_angle_limit_deg.
    * Held at 1, a RealSense-like sensor (noise scale ≈ 2) seen from 1–4 m in a generated
    * room kept 16 % of a frame's points as inliers and was lost from its second frame. */
  double noise_scale = 1.0;
  double max_angle_limit_deg = 60.0;    ///< the widest gate (front and back faces stay apart)
  double convergence_translation = 1e-4;  ///< stop a level when the update is smaller (m)
  double convergence_rotation = 1e-4;     ///< ... and (rad)
  /** Each point-to-plane term is weighted by the inverse variance of the Kinect axial
    * noise σ_z (KinectNoiseModel) at the model point's depth, relative to a point at 1 m:
    * at 3 m a term counts 1/37 of one at 1 m, as its depth is six times noisier (least
    * squares is only the maximum-likelihood estimate with such weights). Measured on
    * 7-Scenes redkitchen: ATE 36.2 → 23.2 mm (docs/benchmarks.md). false = every term 1. */
  bool noise_weighting = true;

  void validate () const;
};

/** \brief The normal gate (degrees) ProjectiveICP uses for a frame whose median depth is
  * \a median_depth (ProjectiveICPConfig::angle_reference_depth). */
double
normalGateDeg (const ProjectiveICPConfig& config, double median_depth);

/** \brief Outcome of ProjectiveICP::align. */
struct ICPResult
{
  Eigen::Isometry3d transform = Eigen::Isometry3d::Identity ();  ///< source camera → target camera
  bool solved = false;               ///< every level had a well-conditioned system
  int iterations = 0;                ///< summed over the levels
  std::size_t source_points = 0;     ///< valid source pixels at the finest level
  std::size_t inliers = 0;           ///< accepted correspondences at the last finest iteration
  std::size_t associated = 0;        ///< source points that met a model point there (before the gates)
  double normal_gate_deg = 0.0;      ///< the normal gate used (normalGateDeg of the frame's median depth)
  double rmse = 0.0;                 ///< point-to-plane RMS of those (metres)
  /** λ_min / λ_max of the (weighted) Σ n nᵀ of the matches on the coarsest level: how
    * well the matched normals constrain the three translations (0 for a plane, which
    * leaves two of them free). The coarsest level's normals are averaged over 4×4
    * pixels, so their noise does not fake constraints: a noisy plane seen by Kinect
    * gives ≤ 0.005 there (0.01–0.02 at the finest level, as much as real rooms). */
  double translation_conditioning = 0.0;
  /** The same ratio for all of the frame's own points on the coarsest level, matched or
    * not (ownTranslationConditioning): how well the surfaces in view could constrain the
    * translations. Low with a low translation_conditioning: the view is a plane or a
    * corridor; high: the frame is fine and only its overlap with the model at the guessed
    * pose is small. Computed by CameraTracker for degenerate systems only (0 otherwise). */
  double source_conditioning = 0.0;

  /** Inliers as a share of the points that met a model point (0 without any): how well
    * the frame agrees with the model where both exist. A right pose in a view the model
    * covers only in part agrees well; a wrong pose does not. */
  double
  agreement () const
  {
    return associated ? static_cast<double> (inliers) / static_cast<double> (associated) : 0.0;
  }

  /** Inliers as a share of the frame's valid points (0 without any). */
  double
  inlierShare () const
  {
    return source_points ? static_cast<double> (inliers) / static_cast<double> (source_points) : 0.0;
  }
};

/** \brief λ_min / λ_max of Σ w n nᵀ over every valid point of \a level (w: the inverse
  * noise variance when \a noise_weighting, as ICP weights its terms): how well the
  * surfaces of one frame constrain the three translations, matched or not. */
double
ownTranslationConditioning (const PyramidLevel& level, bool noise_weighting);

/** \brief Frame-to-model projective point-to-plane ICP, coarse to fine (§4.1.3).
  *
  * Each source vertex (current frame, its camera) is moved by the current estimate into
  * the target camera (the model raycast), projected, and paired with the target vertex
  * on that pixel (projective data association, Blais & Levine; KinectFusion). Pairs
  * further apart than max_distance or with normals more than max_angle apart are
  * rejected. The point-to-plane error Σ (n·(T p − q))² is linearised around the current
  * estimate and the 6×6 normal equations solved; the update is applied on the left.
  *
  * The solver is written here rather than with PCL's
  * TransformationEstimationPointToPlaneLLS: that takes point clouds of correspondences,
  * built anew each iteration. Measured on the 2-core development machine (tabletop view,
  * 640×480, 293k pairs, median of 15): associating into PCL point clouds and solving with
  * TransformationEstimationPointToPlaneLLS took 40 ms; one iteration of this class, which
  * associates and accumulates J^T J in one parallel pass without materialising pairs,
  * 7 ms (that run also counted the valid points in a separate pass, since folded in).
  */
class ProjectiveICP
{
public:
  explicit ProjectiveICP (const ProjectiveICPConfig& config = ProjectiveICPConfig ());

  const ProjectiveICPConfig& getConfig () const { return config_; }

  /** \brief Aligns \a source to \a target starting from \a guess (source → target camera).
    * Both pyramids need as many levels as getConfig().iterations has entries (or more).
    */
  ICPResult
  align (const FramePyramid& source, const FramePyramid& target, const Eigen::Isometry3d& guess) const;

private:
  ProjectiveICPConfig config_;
};
}  // namespace reconstruction
}  // namespace cuefusion
