// SPDX-License-Identifier: BSD-3-Clause
#pragma once

#include <cuefusion/common/pinhole_camera.h>
#include <cuefusion/common/sensor_defaults.h>

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include <cmath>
#include <cstddef>
#include <string>

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

/** \brief Where central-difference normals (§4.1.2) look: one setting for every normal map
  * of a frame. Tracking's pyramid (DepthPreprocessorConfig::normals, level 0) and the
  * geometric segmentation (segmentation::SurfacePreprocessingConfig::normals) each embed
  * one; FusionPipeline gives tracking the segmentation's, so one map serves both.
  */
struct NormalMapConfig
{
  int step = 1;                ///< the differences span ±step pixels (§4.1.2: 1, the 4-neighbourhood)
  float max_depth_jump = kPyramidDepthJump;  ///< a neighbour more than this × z away in depth is across an edge

  /** \brief Throws ParameterError naming the field as \a owner + "." + field (e.g.
    * "SurfacePreprocessingConfig::normals.step"). */
  void validate (const std::string& owner = "NormalMapConfig") const;
};

/** \brief §4.1.2: normals by central differences, n = (V(x+s,y) − V(x−s,y)) × (V(x,y+s) −
  * V(x,y−s)) with s = \a config.step, normalised and turned towards the camera. Where the
  * neighbour on one side lies further than max_depth_jump × z away in depth (a depth edge,
  * not the surface) or is missing, the one-sided difference on the other side is used, so
  * surfaces keep normals up to their outlines; a pixel with no usable neighbour in a
  * direction, an invalid pixel and the \a config.step-wide border get NaN. The only normal
  * formula of the project: centralDifferenceNormalRow computes it.
  */
void
computeNormalMap (const cv::Mat& vertices, cv::Mat& normals, const NormalMapConfig& config = NormalMapConfig ());

/** \brief computeNormalMap on planar coordinates: \a X, \a Y, \a Z are width × height
  * floats each, row after row (NaN marks a missing point); \a NX, \a NY, \a NZ get the
  * normals (NaN where none) and must not overlap the input.
  */
void
computeNormalMapPlanar (const float* X, const float* Y, const float* Z, int width, int height,
                        const NormalMapConfig& config, float* NX, float* NY, float* NZ);

}  // namespace reconstruction
}  // namespace cuefusion
