#pragma once

#include <cuefusion/common/pinhole_camera.h>

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include <cmath>

namespace cuefusion
{
namespace reconstruction
{
/** \brief Vertex at pixel (x, y) of a CV_32FC3 map (NaN x marks "none"). */
inline const Eigen::Vector3f&
vertexAt (const cv::Mat& map, int x, int y)
{
  return *reinterpret_cast<const Eigen::Vector3f*> (map.ptr<cv::Vec3f> (y) + x);
}

inline bool
isValidVertex (const Eigen::Vector3f& v)
{
  return !std::isnan (v.x ());
}

/** \brief §4.1.2: V(u) = K⁻¹ u̇ D(u). \a depth CV_32F metres (0/NaN invalid) → CV_32FC3
  * camera-frame vertices, NaN where the depth is invalid.
  */
void
computeVertexMap (const cv::Mat& depth, const PinholeCamera& camera, cv::Mat& vertices);

/** \brief §4.1.2: normals by central differences over the 4-neighbourhood,
  * n = (V(x+1,y) − V(x−1,y)) × (V(x,y+1) − V(x,y−1)), normalised and turned towards the
  * camera. A pixel gets NaN when a neighbour is missing or lies further than
  * \a max_depth_jump × z from it in depth (a depth edge, not a surface).
  */
void
computeNormalMap (const cv::Mat& vertices, cv::Mat& normals, float max_depth_jump = 0.05f);
}  // namespace reconstruction
}  // namespace cuefusion
