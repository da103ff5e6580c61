// SPDX-License-Identifier: BSD-3-Clause
// Explicit instantiations of the segmentation templates for PCL's point types with x, y, z
// (PCL_XYZ_POINT_TYPES, PCL_INSTANTIATE style), normals as pcl::Normal, and the label
// point types pcl::Label, pcl::PointXYZL and pcl::PointXYZRGBL. Other types work with
// PCL_NO_PRECOMPILE defined before the includes.
#include <cuefusion/segmentation/impl/concavity_edge_estimation.hpp>
#include <cuefusion/segmentation/impl/depth_discontinuity_edge_estimation.hpp>
#include <cuefusion/segmentation/impl/geometric_segmentation.hpp>
#include <cuefusion/segmentation/impl/support_plane_removal.hpp>
#include <cuefusion/segmentation/impl/surface_preprocessing.hpp>

#include <pcl/impl/instantiate.hpp>
#include <pcl/point_types.h>

#define CUEFUSION_INSTANTIATE_GEOMETRIC_SEGMENT(T, LT)                                            \
  template void cuefusion::segmentation::GeometricSegmentation<T, pcl::Normal>::segment<LT> (     \
    pcl::PointCloud<LT>&);                                                                         \
  template void cuefusion::segmentation::GeometricSegmentation<T, pcl::Normal>::segment<LT> (     \
    pcl::PointCloud<LT>&, std::vector<pcl::PointIndices>&);

#define PCL_INSTANTIATE_CuefusionSegmentation(T)                                                  \
  template class cuefusion::segmentation::SurfacePreprocessing<T>;                                \
  template void cuefusion::segmentation::computeCentralDifferenceNormals<T> (                     \
    const pcl::PointCloud<T>&, int, float, pcl::PointCloud<pcl::Normal>&);                        \
  template class cuefusion::segmentation::ConcavityEdgeEstimation<T, pcl::Normal>;                \
  template class cuefusion::segmentation::DepthDiscontinuityEdgeEstimation<T, pcl::Normal>;       \
  template class cuefusion::segmentation::GeometricSegmentation<T, pcl::Normal>;                  \
  CUEFUSION_INSTANTIATE_GEOMETRIC_SEGMENT (T, pcl::Label)                                         \
  CUEFUSION_INSTANTIATE_GEOMETRIC_SEGMENT (T, pcl::PointXYZL)                                     \
  CUEFUSION_INSTANTIATE_GEOMETRIC_SEGMENT (T, pcl::PointXYZRGBL)                                  \
  template class cuefusion::segmentation::SupportPlaneRemoval<T>;                                 \
  template void cuefusion::segmentation::toLabelledCloud<T> (const pcl::PointCloud<T>&, const cv::Mat&, \
                                                             pcl::PointCloud<pcl::PointXYZRGBL>&);

PCL_INSTANTIATE (CuefusionSegmentation, PCL_XYZ_POINT_TYPES)
