// SPDX-License-Identifier: BSD-3-Clause
#pragma once

#include <cuefusion/segmentation/geometric_segmentation.h>
#include <cuefusion/segmentation/impl/cloud_images.hpp>
#include <cuefusion/segmentation/organized_input.h>
#include <cuefusion/segmentation/surface_preprocessing.h>

#include <pcl/common/copy_point.h>
#include <pcl/common/time.h>

#include <cmath>
#include <cstdint>
#include <type_traits>


namespace cuefusion
{
namespace segmentation
{

template <typename PointT, typename PointNT>
void
GeometricSegmentation<PointT, PointNT>::inputPlanes ()
{
  if (!this->config_.preprocess)
  {
    this->toPlanes ("GeometricSegmentation", planes_);
    noise_scale_ = this->config_.noise_scale > 0.f ? this->config_.noise_scale : 1.f;
    return;
  }
  checkOrganizedInput<PointT, PointNT> ("GeometricSegmentation", this->input_.get (), nullptr);  // normals unused
  noise_scale_ = resolveNoiseScale (this->config_, *this->input_);
  SurfacePreprocessing<PointT> preprocessing (this->config_.noiseScaled (noise_scale_).preprocessing);
  preprocessing.setInputCloud (this->input_);
  preprocessing.compute (planes_);
  if (this->hasIndices ())
    keepOnlyIndices ("GeometricSegmentation", *this->indices_, planes_);
}

template <typename PointT, typename PointNT>
template <typename PointLT>
void
GeometricSegmentation<PointT, PointNT>::segment (pcl::PointCloud<PointLT>& labels)
{
  pcl::StopWatch watch;
  inputPlanes ();
  const double copy_ms = watch.getTime ();
  segmentPlanes (planes_);
  timings_.preprocessing_ms = this->config_.preprocess ? copy_ms : 0.0;
  watch.reset ();
  const pcl::PointCloud<PointT>& input = *this->input_;
  labels.resize (input.size ());
  labels.width = input.width;
  labels.height = input.height;
  labels.header = input.header;
  labels.sensor_origin_ = input.sensor_origin_;
  labels.sensor_orientation_ = input.sensor_orientation_;
  if constexpr (pcl::traits::has_xyz_v<PointLT>)
    labels.is_dense = input.is_dense;
  else
    labels.is_dense = true;
  const int width = label_image_.cols;
  parallelFor (label_image_.rows, [&] (int y) {
    const std::int32_t* row = label_image_.ptr<std::int32_t> (y);
    for (int x = 0; x < width; ++x)
    {
      const std::size_t i = static_cast<std::size_t> (y) * width + x;
      PointLT& out = labels[i];
      // Label-only clouds get the label; clouds with coordinates (PointXYZL, PointXYZRGBL,
      // ...) also the input's fields they share (x, y, z, colour).
      if constexpr (!std::is_same_v<PointLT, pcl::Label>)
        pcl::copyPoint (input[i], out);
      // A point without coordinates, or outside the indices, has no segment, as in
      // segment-frame's output (toLabelledCloud): the label image may label a small hole
      // the preprocessing filled (SurfacePreprocessingConfig::max_hole_pixels).
      out.label = std::isfinite (input[i].z) && std::isfinite (planes_.z[i]) ? static_cast<std::uint32_t> (row[x]) : 0u;
    }
  });
  // The copies in and out are charged to the stages they serve.
  if (!this->config_.preprocess)
    timings_.edges_ms += copy_ms;
  timings_.labeling_ms += watch.getTime ();
}

template <typename PointT, typename PointNT>
template <typename PointLT>
void
GeometricSegmentation<PointT, PointNT>::segment (pcl::PointCloud<PointLT>& labels,
                                                 std::vector<pcl::PointIndices>& label_indices)
{
  segment (labels);
  label_indices.assign (static_cast<std::size_t> (segment_count_) + 1, pcl::PointIndices ());
  for (pcl::PointIndices& indices : label_indices)
    indices.header = labels.header;
  // Label 0 lists the points that were in the input (finite, inside the indices) but in
  // no segment; missing points are in no list, as in OrganizedConnectedComponentSegmentation.
  const pcl::PointCloud<PointT>& input = *this->input_;
  const std::size_t n = labels.size ();
  for (std::size_t i = 0; i < n; ++i)
  {
    const std::uint32_t label = labels[i].label;
    if (label != 0 || (std::isfinite (input[i].z) && std::isfinite (planes_.z[i])))
      label_indices[label].indices.push_back (static_cast<pcl::index_t> (i));
  }
}

template <typename PointT, typename PointNT>
void
GeometricSegmentation<PointT, PointNT>::segment (const SurfacePlanes& planes)
{
  noise_scale_ = this->config_.noise_scale > 0.f ? this->config_.noise_scale : 1.f;
  segmentPlanes (planes);
}

template <typename PointT, typename PointNT>
void
GeometricSegmentation<PointT, PointNT>::segmentPlanes (const SurfacePlanes& planes)
{
  const int w = planes.width, h = planes.height;
  if (w < 2 || h < 2 || planes.z.size () != static_cast<std::size_t> (w) * h)
    throw Error ("GeometricSegmentation", "surface planes are empty or not organized");
  timings_ = GeometricSegmentationTimings ();
  const GeometricSegmentationConfig config = this->config_.noiseScaled (noise_scale_);
  pcl::StopWatch watch;
  computeGeometricEdges (planes, config, concavity_edges_, discontinuity_edges_);
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
      // A point without coordinates has no segment (the label image may label a small
      // hole the preprocessing filled: SurfacePreprocessingConfig::max_hole_pixels).
      p.label = std::isfinite (p.z) ? static_cast<std::uint32_t> (labels.at<std::int32_t> (y, x)) : 0u;
    }
}
}  // namespace segmentation
}  // namespace cuefusion
