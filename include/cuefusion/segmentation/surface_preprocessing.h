// SPDX-License-Identifier: BSD-3-Clause
#pragma once

#include <cuefusion/common/sensor_defaults.h>
#include <cuefusion/reconstruction/preprocessing.h>
#include <cuefusion/segmentation/surface_planes.h>

#include <opencv2/core.hpp>

#include <pcl/pcl_base.h>
#include <pcl/point_cloud.h>
#include <pcl/point_types.h>

#include <memory>

namespace cuefusion
{
namespace segmentation
{
/** \brief How SurfacePreprocessing estimates normals. */
enum class NormalMethod
{
  CentralDifference,  ///< §4.1.2: cross product of the horizontal and vertical differences (default)
  IntegralImage       ///< PCL's IntegralImageNormalEstimation, AVERAGE_3D_GRADIENT
};

/** \brief Parameters of SurfacePreprocessing. The defaults were chosen on the osd-learn
  * clouds (docs/benchmarks.md, "Geometric segmentation"): see the comments there.
  */
struct SurfacePreprocessingConfig
{
  /// The depth smoothing (reconstruction::bilateralFilterDepth), its range σ 8 σ_z(z) of the
  /// sensor noise (≈ 1.5 cm at 1 m, 7 cm at 2.5 m): here it must follow the noise
  /// (noise_range_sigma > 0), see SurfacePreprocessing
  reconstruction::BilateralFilterConfig bilateral = segmentationSmoothing ();
  NormalMethod normal_method = NormalMethod::CentralDifference;
  /// CentralDifference's span and depth-edge test (reconstruction::computeNormalMap): ±4
  /// pixels (±1 is too noisy on Kinect data), a neighbour more than 0.02 × z away in depth
  /// is across an edge (IntegralImage uses that factor too)
  reconstruction::NormalMapConfig normals = segmentationNormals ();
  float integral_smoothing = 10.f;    ///< IntegralImage only: normal smoothing size (pixels)
  /** Holes of missing depth of at most this many pixels are filled before smoothing when
    * they lie inside one surface: the valid pixels around the hole fit a plane (inverse
    * depth linear in the pixel coordinates) within normals.max_depth_jump × z. Sensors
    * drop single pixels and small clusters on surfaces seen at grazing angles and far
    * away (a table top at 3 m), and a missing neighbour is a depth edge: unfilled, every
    * dropout ringed itself with edges, the closings joined them and a far table fell
    * apart. A hole across a depth jump (an object's shadow) does not fit a plane and stays.
    * Default: the normals' span squared (4 × 4 px); 0 = off. Filled pixels have points
    * and normals in SurfacePreprocessing's output (so GeometricSegmentation, given that
    * output, sees the same surface) and may carry a segment label.
    */
  int max_hole_pixels = 16;
  void validate () const;

  /** \brief The segmentation's default normals: ±4 pixels, depth jumps of 2 %. */
  static reconstruction::NormalMapConfig
  segmentationNormals ()
  {
    reconstruction::NormalMapConfig c;
    c.step = 4;
    c.max_depth_jump = kSurfaceDepthJump;
    return c;
  }

  /** \brief The segmentation's default smoothing: diameter 5, spatial σ 4.5 px, range σ 8 σ_z(z). */
  static reconstruction::BilateralFilterConfig
  segmentationSmoothing ()
  {
    reconstruction::BilateralFilterConfig c;
    c.noise_range_sigma = 8.0;
    return c;
  }
};

/** \brief Preprocessing of an organized cloud for the geometric segmentation (§4.1.2):
  * edge-preserving smoothing of depth and a normal map.
  *
  * Depth is smoothed with a bilateral filter whose range σ follows the Kinect noise model
  * (noiseAdaptiveBilateral): a fixed range σ in metres either leaves far surfaces noisy
  * or blurs near convex boundaries — the concern of §4.1.2, where a convex boundary
  * between two objects is only a small depth step. Invalid points are kept out of every
  * average; each smoothed point moves along its own viewing ray, so no intrinsics are
  * needed. PCL's FastBilateralFilter was not used: it turns NaN depth into finite z with
  * NaN x/y.
  *
  * Normals by central differences, as §4.1.2 does, over ±normals.step pixels; near a depth
  * edge the one-sided difference on the near side is used, so objects keep normals up to
  * their boundary. Normals point towards the sensor. IntegralImageNormalEstimation is the
  * alternative (NormalMethod::IntegralImage); the two were measured against exact normals
  * of noisy synthetic views (docs/benchmarks.md).
  */
template <typename PointT>
class SurfacePreprocessing : public pcl::PCLBase<PointT>
{
public:
  using Ptr = std::shared_ptr<SurfacePreprocessing>;
  using ConstPtr = std::shared_ptr<const SurfacePreprocessing>;

  explicit SurfacePreprocessing (const SurfacePreprocessingConfig& config = SurfacePreprocessingConfig ())
  {
    setConfig (config);
  }

  /** \brief Throws cuefusion::ParameterError for an invalid configuration. */
  void setConfig (const SurfacePreprocessingConfig& config);
  const SurfacePreprocessingConfig& getConfig () const { return config_; }

  /** \brief Smoothed copy of the input (same size, other fields untouched) and its
    * organized normals (NaN where none). Throws cuefusion::Error on unorganized, empty
    * or all-NaN input. \a smoothed may not be the input cloud itself.
    */
  void compute (pcl::PointCloud<PointT>& smoothed, pcl::PointCloud<pcl::Normal>& normals);

  /** \brief The same as SurfacePlanes (smoothed points and normals, NaN where none),
    * without the copies into PCL clouds: the fast path into GeometricSegmentation.
    */
  void compute (SurfacePlanes& planes);

  /** \brief Milliseconds of the last compute: smoothing, normals. */
  double getSmoothingTime () const { return smoothing_ms_; }
  double getNormalTime () const { return normal_ms_; }

protected:
  using pcl::PCLBase<PointT>::input_;

  SurfacePreprocessingConfig config_;
  SurfacePlanes planes_;
  double smoothing_ms_ = 0.0;
  double normal_ms_ = 0.0;
};

/** \brief The smoothing and normals of SurfacePreprocessing on planes whose points are
  * already set (e.g. by SurfacePlanes::assignDepth): smooths x, y, z in place and fills
  * the normal planes. Milliseconds of each part go to \a smoothing_ms / \a normal_ms.
  */
void
preprocessPlanes (SurfacePlanes& planes, const SurfacePreprocessingConfig& config, double* smoothing_ms = nullptr,
                  double* normal_ms = nullptr);

/** \brief Fills holes of missing depth (connected, 8-neighbourhood) of at most
  * \a max_hole_pixels pixels that lie inside one surface: the valid pixels around the
  * hole fit a plane (inverse depth and the rays linear in the pixel coordinates) within
  * \a max_depth_jump × z. Holes open to the image border stay. With \a fill_normals, filled
  * pixels also get the mean normal of the pixels around the hole (for planes whose normals
  * are already computed). Returns the pixels filled. SurfacePreprocessingConfig::max_hole_pixels.
  */
std::size_t
fillSmallHoles (SurfacePlanes& planes, int max_hole_pixels, float max_depth_jump, bool fill_normals);

/** \brief The noise-adaptive bilateral filter (declared in reconstruction/preprocessing.h:
  * tracking's preprocessing can use it too, and the pipeline smooths once for both).
  */
using reconstruction::noiseAdaptiveBilateral;

/** \brief Central-difference normals of an organized cloud (see SurfacePreprocessing). */
template <typename PointT>
void
computeCentralDifferenceNormals (const pcl::PointCloud<PointT>& cloud, int step, float max_depth_jump,
                                 pcl::PointCloud<pcl::Normal>& normals);
}  // namespace segmentation
}  // namespace cuefusion

#ifdef PCL_NO_PRECOMPILE
#include <cuefusion/segmentation/impl/surface_preprocessing.hpp>
#endif
