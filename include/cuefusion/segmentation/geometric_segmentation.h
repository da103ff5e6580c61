// SPDX-License-Identifier: BSD-3-Clause
#pragma once

#include <cuefusion/common/sensor_defaults.h>
#include <cuefusion/segmentation/concavity_edge_estimation.h>
#include <cuefusion/segmentation/depth_discontinuity_edge_estimation.h>
#include <cuefusion/segmentation/segment_size.h>
#include <cuefusion/segmentation/surface_planes.h>
#include <cuefusion/segmentation/surface_preprocessing.h>

#include <opencv2/core.hpp>

#include <pcl/PointIndices.h>
#include <pcl/point_cloud.h>
#include <pcl/point_types.h>

#include <algorithm>
#include <memory>
#include <vector>

namespace cuefusion
{
namespace segmentation
{
/** \brief Parameters of the labelling half of GeometricSegmentation (edge map → L^G). */
struct EdgeLabelingConfig
{
  int closing_iterations = 2;       ///< §4.2.1.1: closings of the edge map (3×3 kernel); 0 switches it off
  int min_segment_size = kMinSegmentPixels;///< smaller connected components are relabelled 0 (pixels)
  /** Edge pixels with valid depth are given to the adjacent segment they continue in
    * depth (breadth-first, at most this many pixels out; 0 = off: edge pixels stay 0).
    * The edge band is 2–4 px wide after closing; without this every object loses a rim
    * that wide.
    */
  int edge_assignment_radius = 4;
  float max_depth_jump = kSurfaceDepthJump;  ///< growing into an edge pixel needs |Δz| < this × z
  void validate () const;
};

/** \brief Parameters of GeometricSegmentation (§4.2.1.1). */
struct GeometricSegmentationConfig
{
  /** segment() on a cloud first applies the surface preprocessing `cuefusion segment-frame`
    * and the pipeline apply (SurfacePreprocessing with \a preprocessing: noise-adaptive
    * smoothing of the depth, small holes filled, the normals of §4.1.2), so a class used
    * on its own gives the command's segments. Raw sensor depth needs it: on a noisy
    * generated frame the unsmoothed cloud with PCL's integral-image normals left objects
    * below 0.75 IoU that the command segments whole
    * (SegmentFrame.TheLibraryOnItsOwnGivesTheCommandsSegments). On (the default), input normals are not needed and not used; off, the
    * cloud and normals given are segmented as they are (input already smoothed, or
    * normals of your own). segment(planes) never preprocesses.
    */
  bool preprocess = true;
  SurfacePreprocessingConfig preprocessing;
  bool use_concavity_edges = true;
  bool use_discontinuity_edges = true;
  ConcavityEdgeEstimationConfig concavity;
  DepthDiscontinuityEdgeEstimationConfig discontinuity;
  EdgeLabelingConfig labeling;
  /** The depth's noise as a multiple of the Kinect model σ_z(z) (Nguyen et al. 2012) that
    * the segmentation's noise thresholds are written in: the smoothing's range σ
    * (preprocessing.bilateral.noise_range_sigma), the concavity's noise slopes, the wide
    * test's span (concavity.wide_noise_scale) and the
    * depth-edge factor k are multiplied by it (noiseScaled). 0 (the default): measured
    * from each cloud's depth before smoothing (reconstruction::estimateDepthNoise) and
    * never taken below 1, since the thresholds were set on Kinect-class noise — so a
    * RealSense-like stereo camera (about twice that noise beyond a metre) is segmented
    * as a Kinect is, instead of into splinters; > 0: this scale. segment (planes) cannot
    * measure (its depth is smoothed already) and uses 1 when this is 0.
    */
  float noise_scale = 0.f;
  void validate () const;
  /** \brief A copy whose noise thresholds (see noise_scale) are multiplied by \a scale. */
  GeometricSegmentationConfig noiseScaled (float scale) const;
  /** \brief True when the scale is measured (noise_scale 0). */
  bool measuresNoise () const { return noise_scale <= 0.f; }
  /** \brief The scale the thresholds take: noise_scale when above 0, else \a measured_ratio
    * (a depth's noise over the Kinect model's), never below 1. The one home of that rule. */
  float scaleFor (float measured_ratio) const { return measuresNoise () ? std::max (1.f, measured_ratio) : noise_scale; }
};

/** \brief The scale noise_scale stands for on a depth image (CV_32F metres, 0 or NaN
  * invalid, before smoothing): \a config.noise_scale when above 0, else the depth's
  * measured noise ratio (reconstruction::estimateDepthNoise), at least 1 — 1 too where no
  * patch could be measured.
  */
float
resolveNoiseScale (const GeometricSegmentationConfig& config, const cv::Mat& raw_depth);

/** \brief A raw depth image's noise over the Kinect model's (CV_32F metres;
  * reconstruction::estimateDepthNoise's ratio). */
float
measureNoiseRatio (const cv::Mat& raw_depth);

/** \brief The depth noise of an organized cloud as the sensor gave it (its z) over the
  * Kinect model's (reconstruction::estimateDepthNoise's ratio; 0 for exact depth). */
template <typename PointT>
float
measureNoiseRatio (const pcl::PointCloud<PointT>& cloud)
{
  cv::Mat raw_depth (static_cast<int> (cloud.height), static_cast<int> (cloud.width), CV_32F);
  float* z = raw_depth.ptr<float> ();
  for (std::size_t i = 0; i < cloud.size (); ++i)
    z[i] = cloud[i].z;
  return measureNoiseRatio (raw_depth);
}

/** \brief resolveNoiseScale on an organized cloud as the sensor gave it (its z). */
template <typename PointT>
float
resolveNoiseScale (const GeometricSegmentationConfig& config, const pcl::PointCloud<PointT>& cloud)
{
  return config.measuresNoise () ? config.scaleFor (measureNoiseRatio (cloud)) : config.scaleFor (0.f);
}

/** \brief Milliseconds spent per stage by the last GeometricSegmentation::segment. */
struct GeometricSegmentationTimings
{
  double preprocessing_ms = 0.0;  ///< GeometricSegmentationConfig::preprocess: smoothing, holes and normals
  double edges_ms = 0.0;      ///< both edge operators (one pass when their neighbour steps agree)
  double labeling_ms = 0.0;   ///< union, closing, connected components, small segments, edge assignment
};

/** \brief The edge maps of §4.2.1.1 that GeometricSegmentation labels (CV_8U, 1 = edge):
  * concave and depth-discontinuity edges, each all 0 when switched off in \a config; one
  * pass over the planes when both run at the same neighbour step.
  */
void
computeGeometricEdges (const SurfacePlanes& planes, const GeometricSegmentationConfig& config, cv::Mat& concave,
                       cv::Mat& depth_edges);

/** \brief Labels an edge map (§4.2.1.1 "Labeling the edge map").
  * \param[in] edges CV_8U, non-zero = edge
  * \param[in] depth CV_32F depth (z) in metres, NaN or ≤ 0 = invalid
  * \param[out] labels CV_32S, 0 = no segment (invalid, edge, or a segment that was too small),
  *             segments numbered 1..N in raster order of their first pixel
  * \return N
  *
  * Invalid pixels count as edges for the closings, so a boundary that runs into a hole
  * is closed against it. Connected components use 4-connectivity.
  */
int
labelEdgeMap (const cv::Mat& edges, const cv::Mat& depth, const EdgeLabelingConfig& config, cv::Mat& labels);

/** \brief The geometric label map L^G of §4.2.1.1 from an organized cloud (preprocessed as
  * the command line does unless GeometricSegmentationConfig::preprocess is off; then with
  * the normals given): concavity edges (ConcavityEdgeEstimation) ∪ depth-discontinuity edges
  * (DepthDiscontinuityEdgeEstimation), two closings, connected components of the
  * remaining valid pixels, small segments dropped (labelEdgeMap). Each step can be
  * switched off in the config for ablation.
  *
  * \code
  * GeometricSegmentation<pcl::PointXYZRGBA, pcl::Normal> segmentation;
  * segmentation.setInputCloud (cloud);           // organized, as the sensor gave it
  * segmentation.setIndices (roi);               // optional: only these points
  * pcl::PointCloud<pcl::Label> labels;           // 0 = no segment
  * std::vector<pcl::PointIndices> label_indices; // [l] = the points of segment l
  * segmentation.segment (labels, label_indices);
  * \endcode
  */
template <typename PointT, typename PointNT>
class GeometricSegmentation : public OrganizedCloudWithNormals<PointT, PointNT, GeometricSegmentationConfig>
{
public:
  using Ptr = std::shared_ptr<GeometricSegmentation>;
  using ConstPtr = std::shared_ptr<const GeometricSegmentation>;

  explicit GeometricSegmentation (const GeometricSegmentationConfig& config = GeometricSegmentationConfig ())
  {
    this->setConfig (config);
  }

  /** \brief Organized labels of the input's size: segments 1..N, 0 = no segment. With
    * indices (setIndices) only their points are segmented; every other point is treated
    * as missing depth and labelled 0. \a PointLT is any point type with a label field:
    * pcl::Label gets only the label, types with coordinates (pcl::PointXYZL,
    * pcl::PointXYZRGBL, ...) also the input's x, y, z and colour, ready for pcl_viewer.
    * With preprocessing (the default) the whole cloud's noise is measured (noise_scale),
    * it is smoothed and its normals found, then the points outside the indices are dropped; without, setInputNormals is needed.
    * Throws cuefusion::Error on unorganized, empty or all-NaN input, normals of another
    * size and an index outside the cloud.
    */
  template <typename PointLT>
  void segment (pcl::PointCloud<PointLT>& labels);

  /** \brief The same, and the points of each label as in
    * pcl::OrganizedConnectedComponentSegmentation: label_indices[l] lists the points of
    * segment l (1..N, size N + 1); label_indices[0] the points that were segmented but
    * fell in no segment (edges that were not given to a segment, small segments).
    * Missing points and points outside the indices are in no list.
    */
  template <typename PointLT>
  void segment (pcl::PointCloud<PointLT>& labels, std::vector<pcl::PointIndices>& label_indices);

  /** \brief The same on SurfacePlanes (e.g. from SurfacePreprocessing::compute(planes)),
    * without the copies from and to PCL clouds; the input cloud and normals are not used.
    * Results via getLabelImage() and the other getters.
    */
  void segment (const SurfacePlanes& planes);

  /** \brief The noise scale the last segment() used (GeometricSegmentationConfig::noise_scale
    * resolved: measured on a cloud, or as configured).
    */
  float getNoiseScale () const { return noise_scale_; }

  /** \brief Results of the last segment(): L^G (CV_32S), the edge maps (CV_8U, 1 = edge;
    * the union is before closing), the number of segments and the timings.
    */
  const cv::Mat& getLabelImage () const { return label_image_; }
  const cv::Mat& getConcavityEdges () const { return concavity_edges_; }
  const cv::Mat& getDiscontinuityEdges () const { return discontinuity_edges_; }
  const cv::Mat& getEdges () const { return edges_; }
  int getSegmentCount () const { return segment_count_; }
  const GeometricSegmentationTimings& getTimings () const { return timings_; }

protected:
  /** \brief The input as SurfacePlanes: preprocessed (config preprocess) or as given. */
  void inputPlanes ();
  /** \brief segment (planes) with the noise thresholds multiplied by noise_scale_. */
  void segmentPlanes (const SurfacePlanes& planes);

  float noise_scale_ = 1.f;

  SurfacePlanes planes_;  ///< reused between frames
  cv::Mat label_image_, concavity_edges_, discontinuity_edges_, edges_;
  int segment_count_ = 0;
  GeometricSegmentationTimings timings_;
};

/** \brief Copies points (and colour, when PointT has one) of \a cloud with the labels of
  * \a labels (CV_32S, the cloud's size) into an organized PointXYZRGBL cloud.
  */
template <typename PointT>
void
toLabelledCloud (const pcl::PointCloud<PointT>& cloud, const cv::Mat& labels, pcl::PointCloud<pcl::PointXYZRGBL>& out);
}  // namespace segmentation
}  // namespace cuefusion

#ifdef PCL_NO_PRECOMPILE
#include <cuefusion/segmentation/impl/geometric_segmentation.hpp>
#endif
