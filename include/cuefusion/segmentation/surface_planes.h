// SPDX-License-Identifier: BSD-3-Clause
#pragma once

#include <cuefusion/reconstruction/vertex_maps.h>
#include <cuefusion/segmentation/parallel.h>

#include <pcl/point_cloud.h>
#include <pcl/point_types.h>

#include <opencv2/core.hpp>

#include <cmath>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <vector>

namespace cuefusion
{
namespace segmentation
{
enum class ConvexityTest;
struct ConcavityEdgeEstimationConfig;

/** \brief Points and normals of an organized cloud as six float planes (row-major, NaN =
  * none). The edge operators run over these one neighbour direction at a time, so the
  * compiler vectorises the inner loop across pixels; on PCL's interleaved point structs
  * the same loops ran 4–5× slower (measured on osd-learn, docs/benchmarks.md).
  */
struct SurfacePlanes
{
  int width = 0, height = 0;
  std::vector<float> x, y, z, nx, ny, nz;

  /** \brief Writes the normal planes into an organized pcl::Normal cloud (curvature 0,
    * NaN where there is no normal).
    */
  void
  copyNormalsTo (pcl::PointCloud<pcl::Normal>& normals) const
  {
    normals.resize (x.size ());
    normals.width = static_cast<std::uint32_t> (width);
    normals.height = static_cast<std::uint32_t> (height);
    normals.is_dense = false;
    parallelFor (x.size (), [&] (std::size_t i) {
      pcl::Normal& n = normals[i];
      n.normal_x = nx[i];
      n.normal_y = ny[i];
      n.normal_z = nz[i];
      n.curvature = std::isfinite (nx[i]) ? 0.f : std::numeric_limits<float>::quiet_NaN ();
    });
  }

  /** \brief Copies \a cloud's points (x, y, z all finite and z > 0, else NaN); leaves the normal
    * planes sized but unset.
    */
  template <typename PointT>
  void
  assignPoints (const pcl::PointCloud<PointT>& cloud)
  {
    width = static_cast<int> (cloud.width);
    height = static_cast<int> (cloud.height);
    const std::size_t n = cloud.size ();
    for (std::vector<float>* plane : {&x, &y, &z, &nx, &ny, &nz})
      plane->resize (n);
    const float nan = std::numeric_limits<float>::quiet_NaN ();
    parallelFor (n, [&] (std::size_t i) {
      const PointT& p = cloud[i];
      const bool valid = std::isfinite (p.x) && std::isfinite (p.y) && std::isfinite (p.z) && p.z > 0.f;
      x[i] = valid ? p.x : nan;
      y[i] = valid ? p.y : nan;
      z[i] = valid ? p.z : nan;
    });
  }

  /** \brief Points back-projected from a depth map (CV_32F metres, ≤ 0 or NaN invalid)
    * through pinhole intrinsics; the normal planes are sized but unset.
    */
  void assignDepth (const cv::Mat& depth, double fx, double fy, double cx, double cy);

  /** \brief Takes the normal planes from a normal map of the same size (CV_32FC3, NaN =
    * none), e.g. tracking's level 0 (reconstruction::computeNormalMap), which FusionPipeline
    * shares instead of computing a second map of the same frame.
    */
  void assignNormals (const cv::Mat& normals);

  /** \brief Copies \a cloud's points and \a normals' normal_x/y/z (same size, organized).
    * A point counts only when x, y and z are all finite and z > 0; a normal only when its point does.
    */
  template <typename PointT, typename PointNT>
  void
  assign (const pcl::PointCloud<PointT>& cloud, const pcl::PointCloud<PointNT>& normals)
  {
    assignPoints (cloud);
    const float nan = std::numeric_limits<float>::quiet_NaN ();
    parallelFor (cloud.size (), [&] (std::size_t i) {
      const auto& q = normals[i];
      const bool has_normal =
        std::isfinite (z[i]) && std::isfinite (q.normal_x) && std::isfinite (q.normal_y) && std::isfinite (q.normal_z);
      nx[i] = has_normal ? q.normal_x : nan;
      ny[i] = has_normal ? q.normal_y : nan;
      nz[i] = has_normal ? q.normal_z : nan;
    });
  }
};

/** \brief Central-difference normals (§4.1.2) into the normal planes, from the point
  * planes: reconstruction::computeNormalMap's formula (over ±step pixels, one-sided on the
  * near side of a depth edge, NaN where neither side is usable, oriented towards the
  * sensor).
  */
void
computeNormalPlanes (SurfacePlanes& planes, const reconstruction::NormalMapConfig& config);

/** \brief Φ(u) of §4.2.1.1 for every pixel (CV_32F; NaN where u has no point or normal). */
void
computeConcavityMap (const SurfacePlanes& planes, int step, ConvexityTest test, cv::Mat& phi);

/** \brief Γ(u) of §4.2.1.1 for every pixel (CV_32F metres; +inf next to a missing
  * neighbour or without a normal, NaN where u has no point).
  */
void
computeDiscontinuityMap (const SurfacePlanes& planes, int step, cv::Mat& gamma);

/** \brief Edge mask (CV_8U, 1 = edge) from Φ: Φ < the threshold of \a config at each
  * pixel's depth (ConcavityEdgeEstimationConfig::noise_slope).
  */
void
concavityEdges (const SurfacePlanes& planes, const cv::Mat& phi, const ConcavityEdgeEstimationConfig& config, cv::Mat& edges);

/** \brief Edge mask (CV_8U, 1 = edge) from Γ: Γ > k·σ_d(u), σ_d at each pixel's depth
  * and viewing angle; +inf always an edge, NaN never.
  */
void
discontinuityEdges (const SurfacePlanes& planes, const cv::Mat& gamma, float k, cv::Mat& edges);
/** \brief Both edge masks of §4.2.1.1 in one pass over the planes (the operators read
  * the same points and normals), both at \a concavity's neighbour step: concave (as
  * concavityEdges) and depth discontinuity (Γ > k·σ_d), CV_8U, 1 = edge. Without the Φ
  * and Γ images.
  */
void
computeEdgeMasks (const SurfacePlanes& planes, const ConcavityEdgeEstimationConfig& concavity, float noise_factor, cv::Mat& concave,
                  cv::Mat& depth_edges);
}  // namespace segmentation
}  // namespace cuefusion
