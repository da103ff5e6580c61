// SPDX-License-Identifier: BSD-3-Clause
#pragma once

#include <cuefusion/common/instance.h>
#include <cuefusion/pipeline/fusion_pipeline.h>
#include <cuefusion/segmentation/geometric_segmentation.h>
#include <cuefusion/segmentation/instance_guided_region_merge.h>
#include <cuefusion/segmentation/surface_planes.h>
#include <cuefusion/segmentation/surface_preprocessing.h>

#include <pcl/point_cloud.h>
#include <pcl/point_types.h>

#include <vector>

namespace cuefusion
{
namespace pipeline
{
/** \brief What segments one frame on its own: the geometric cue and how masks join it. */
struct FrameSegmentationConfig
{
  segmentation::GeometricSegmentationConfig geometry;
  segmentation::InstanceGuidedRegionMergeConfig instance_merge;
  SegmentationMode mode = SegmentationMode::Fused;
  void validate () const;
};

/** \brief One frame's segments L_t without a map (thesis §4.2.1): the depth's noise
  * measured on the frame (GeometricSegmentationConfig::noise_scale 0), smoothing and
  * normals (SurfacePreprocessing), L^G (GeometricSegmentation), and with masks L_t
  * (InstanceGuidedRegionMerge in fused mode, the masks alone in masks mode). What
  * `cuefusion segment-frame` and the Python `segment_frame` run.
  *
  * Two steps, as the cues come: segmentGeometry(cloud) gives L^G; applyMasks(instances)
  * then gives L_t (a network that needs the frame runs in between).
  */
class FrameSegmentation
{
public:
  using Cloud = pcl::PointCloud<pcl::PointXYZRGBA>;

  explicit FrameSegmentation (const FrameSegmentationConfig& config = FrameSegmentationConfig ());
  const FrameSegmentationConfig& getConfig () const { return config_; }

  /** \brief L^G of an organized cloud (NaN points: no depth), CV_32S, 0 = no segment.
    * Throws cuefusion::Error when the cloud is not organized. */
  const cv::Mat& segmentGeometry (const Cloud::ConstPtr& cloud);

  /** \brief L_t of the last segmentGeometry's cloud with \a instances (the frame's size):
    * fused or masks alone by the mode (geometry mode: L^G unchanged). \a color (CV_8UC3,
    * BGR, may be empty) divides masks over clearly different colours. \a segments
    * receives what each label is (its instance, class, score). */
  cv::Mat applyMasks (const std::vector<Instance>& instances, const cv::Mat& color,
                      std::vector<segmentation::SegmentInstance>* segments = nullptr) const;

  /** \brief The depth noise the last frame was measured at (a multiple of Kinect's). */
  float noiseScale () const { return segmenter_.getNoiseScale (); }
  const segmentation::SurfacePlanes& planes () const { return planes_; }
  const segmentation::GeometricSegmentation<pcl::PointXYZRGBA, pcl::Normal>& geometricSegmentation () const { return segmenter_; }
  double smoothingTime () const { return preprocessor_.getSmoothingTime (); }
  double normalTime () const { return preprocessor_.getNormalTime (); }

private:
  FrameSegmentationConfig config_;
  segmentation::SurfacePreprocessing<pcl::PointXYZRGBA> preprocessor_;
  segmentation::GeometricSegmentation<pcl::PointXYZRGBA, pcl::Normal> segmenter_;
  segmentation::InstanceGuidedRegionMerge merger_;
  segmentation::SurfacePlanes planes_;
};
}  // namespace pipeline
}  // namespace cuefusion
