// Explicit instantiations of the segmentation templates for the common point types
// (PCL style); other types work with PCL_NO_PRECOMPILE defined before the includes.
#include <cuefusion/segmentation/impl/concavity_edge_estimation.hpp>
#include <cuefusion/segmentation/impl/depth_discontinuity_edge_estimation.hpp>
#include <cuefusion/segmentation/impl/geometric_segmentation.hpp>
#include <cuefusion/segmentation/impl/support_plane_removal.hpp>
#include <cuefusion/segmentation/impl/surface_preprocessing.hpp>

#define CUEFUSION_INSTANTIATE_SEGMENTATION(T)                                                     \
  template class cuefusion::segmentation::SurfacePreprocessing<T>;                                \
  template void cuefusion::segmentation::computeCentralDifferenceNormals<T> (                     \
    const pcl::PointCloud<T>&, int, float, pcl::PointCloud<pcl::Normal>&);                        \
  template class cuefusion::segmentation::ConcavityEdgeEstimation<T, pcl::Normal>;                \
  template class cuefusion::segmentation::DepthDiscontinuityEdgeEstimation<T, pcl::Normal>;       \
  template class cuefusion::segmentation::GeometricSegmentation<T, pcl::Normal>;                  \
  template class cuefusion::segmentation::SupportPlaneRemoval<T>;                                 \
  template void cuefusion::segmentation::toLabelledCloud<T> (const pcl::PointCloud<T>&, const cv::Mat&, \
                                                             pcl::PointCloud<pcl::PointXYZRGBL>&);

CUEFUSION_INSTANTIATE_SEGMENTATION (pcl::PointXYZ)
CUEFUSION_INSTANTIATE_SEGMENTATION (pcl::PointXYZRGB)
CUEFUSION_INSTANTIATE_SEGMENTATION (pcl::PointXYZRGBA)
CUEFUSION_INSTANTIATE_SEGMENTATION (pcl::PointXYZRGBL)
CUEFUSION_INSTANTIATE_SEGMENTATION (pcl::PointXYZL)
