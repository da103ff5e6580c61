#pragma once

#include <cuefusion/segmentation/geometric_segmentation.h>
#include <cuefusion/segmentation/impl/cloud_images.hpp>
#include <cuefusion/segmentation/organized_input.h>

#include <pcl/common/time.h>


namespace cuefusion
{
namespace segmentation
{

template <typename PointT, typename PointNT>
void
GeometricSegmentation<PointT, PointNT>::segment (pcl::PointCloud<pcl::Label>& labels)
{
  pcl::StopWatch watch;
  this->toPlanes ("GeometricSegmentation", planes_);
  const double copy_ms = watch.getTime ();
  segment (planes_);
  watch.reset ();
  detail::copyToCloud (label_image_, labels);
  // The copies in and out are charged to the stages they serve.
  timings_.edges_ms += copy_ms;
  timings_.labeling_ms += watch.getTime ();
}

template <typename PointT, typename PointNT>
void
GeometricSegmentation<PointT, PointNT>::segment (const SurfacePlanes& planes)
{
  const int w = planes.width, h = planes.height;
  if (w < 2 || h < 2 || planes.z.size () != static_cast<std::size_t> (w) * h)
    throw Error ("GeometricSegmentation", "surface planes are empty or not organized");
  timings_ = GeometricSegmentationTimings ();
  const GeometricSegmentationConfig& config = this->config_;
  pcl::StopWatch watch;
  const bool both = config.use_concavity_edges && config.use_discontinuity_edges;
  if (both && config.concavity.neighbour_step == config.discontinuity.neighbour_step)
    computeEdgeMasks (planes, config.concavity, config.discontinuity.noise_factor, concavity_edges_, discontinuity_edges_);
  else
  {
    cv::Mat values;
    concavity_edges_ = cv::Mat::zeros (h, w, CV_8U);
    if (config.use_concavity_edges)
    {
      computeConcavityMap (planes, config.concavity.neighbour_step, config.concavity.convexity_test, values);
      concavityEdges (planes, values, config.concavity, concavity_edges_);
    }
    discontinuity_edges_ = cv::Mat::zeros (h, w, CV_8U);
    if (config.use_discontinuity_edges)
    {
      computeDiscontinuityMap (planes, config.discontinuity.neighbour_step, values);
      discontinuityEdges (planes, values, config.discontinuity.noise_factor, discontinuity_edges_);
    }
  }
  timings_.edges_ms = watch.getTime ();

  watch.reset ();
  cv::bitwise_or (concavity_edges_, discontinuity_edges_, edges_);
  const cv::Mat depth (h, w, CV_32F, const_cast<float*> (planes.z.data ()));
  segment_count_ = labelEdgeMap (edges_, depth, config.labeling, label_image_);
  timings_.labeling_ms = watch.getTime ();
}

template <typename PointT>
void
toLabelledCloud (const pcl::PointCloud<PointT>& cloud, const cv::Mat& labels, pcl::PointCloud<pcl::PointXYZRGBL>& out)
{
  if (labels.type () != CV_32S || labels.cols != static_cast<int> (cloud.width) ||
      labels.rows != static_cast<int> (cloud.height))
    throw Error ("toLabelledCloud", "label image does not match the cloud's size");
  out.resize (cloud.size ());
  out.width = cloud.width;
  out.height = cloud.height;
  out.is_dense = cloud.is_dense;
  for (int y = 0; y < labels.rows; ++y)
    for (int x = 0; x < labels.cols; ++x)
    {
      const std::size_t i = static_cast<std::size_t> (y) * labels.cols + x;
      pcl::PointXYZRGBL& p = out[i];
      p.getVector3fMap () = cloud[i].getVector3fMap ();
      if constexpr (pcl::traits::has_color_v<PointT>)
      {
        p.r = cloud[i].r;
        p.g = cloud[i].g;
        p.b = cloud[i].b;
      }
      else
        p.r = p.g = p.b = 255;
      p.a = 255;
      p.label = static_cast<std::uint32_t> (labels.at<std::int32_t> (y, x));
    }
}
}  // namespace segmentation
}  // namespace cuefusion
