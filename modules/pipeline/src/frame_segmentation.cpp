// SPDX-License-Identifier: BSD-3-Clause
#include <cuefusion/common/exceptions.h>
#include <cuefusion/pipeline/frame_segmentation.h>

namespace cuefusion
{
namespace pipeline
{
void
FrameSegmentationConfig::validate () const
{
  geometry.validate ();
  instance_merge.validate ();
}

FrameSegmentation::FrameSegmentation (const FrameSegmentationConfig& config)
  : config_ (config)
  , preprocessor_ (config.geometry.preprocessing)
  , segmenter_ (config.geometry)
  , merger_ (config.instance_merge)
{
  config_.validate ();
}

const cv::Mat&
FrameSegmentation::segmentGeometry (const Cloud::ConstPtr& cloud)
{
  if (!cloud || cloud->height < 2 || cloud->empty ())
    throw Error ("FrameSegmentation", "needs an organized (image-shaped) cloud");
  // The frame's noise sets the thresholds written in sensor-noise units
  // (GeometricSegmentationConfig::noise_scale), as GeometricSegmentation::segment does.
  segmentation::GeometricSegmentationConfig geo = config_.geometry;
  if (config_.geometry.measuresNoise ())
  {
    // The measured ratio also says where the masks' rim follows the normals, as in FusionPipeline.
    const float ratio = segmentation::measureNoiseRatio (*cloud);
    geo.noise_scale = config_.geometry.scaleFor (ratio);
    segmentation::InstanceGuidedRegionMergeConfig merge = config_.instance_merge;
    merge.noise_ratio = ratio;
    merger_ = segmentation::InstanceGuidedRegionMerge (merge);
  }
  else
    geo.noise_scale = config_.geometry.scaleFor (0.f);
  preprocessor_.setConfig (geo.noiseScaled (geo.noise_scale).preprocessing);
  segmenter_.setConfig (geo);
  preprocessor_.setInputCloud (cloud);
  preprocessor_.compute (planes_);
  segmenter_.segment (planes_);
  return segmenter_.getLabelImage ();
}

cv::Mat
FrameSegmentation::applyMasks (const std::vector<Instance>& instances, const cv::Mat& color,
                               std::vector<segmentation::SegmentInstance>* segments) const
{
  const cv::Mat& geometric = segmenter_.getLabelImage ();
  for (const Instance& instance : instances)
    if (instance.mask.size () != geometric.size () || instance.mask.type () != CV_8U)
      throw ParameterError ("instances", "a mask is not a CV_8U image of the frame's size");
  cv::Mat labels;
  switch (config_.mode)
  {
  case SegmentationMode::Fused:
    merger_.merge (geometric, instances, labels, segments, &planes_, color);
    break;
  case SegmentationMode::Masks:
    segmentation::masksAsSegments (instances, planes_, labels, segments);
    break;
  case SegmentationMode::Geometry:
    labels = geometric.clone ();
    break;
  }
  return labels;
}
}  // namespace pipeline
}  // namespace cuefusion
