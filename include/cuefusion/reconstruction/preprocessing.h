// SPDX-License-Identifier: BSD-3-Clause
#pragma once

#include <cuefusion/common/pinhole_camera.h>
#include <cuefusion/common/sensor_defaults.h>
#include <cuefusion/reconstruction/vertex_maps.h>

#include <opencv2/core.hpp>

#include <string>
#include <vector>

namespace cuefusion
{
namespace reconstruction
{
/** \brief Depth preprocessing for tracking (§4.1.2). */
/** \brief The edge-preserving depth smoothing of §4.1.2 (bilateralFilterDepth), one config
  * for tracking's preprocessing (DepthPreprocessorConfig::bilateral: KinectFusion's fixed
  * range σ of 3 cm) and the geometric segmentation's
  * (segmentation::SurfacePreprocessingConfig::bilateral: a range σ that follows the sensor
  * noise). FusionPipeline gives tracking the segmentation's, so one filter serves both.
  */
struct BilateralFilterConfig
{
  bool enabled = true;
  int diameter = 5;                  ///< window (pixels)
  double sigma_space = 4.5;          ///< spatial σ (pixels), KinectFusion's
  /// > 0: the range σ follows the sensor noise, this many σ_z(z) (noiseAdaptiveBilateral);
  /// 0: it is range_sigma_metres everywhere
  double noise_range_sigma = 0.0;
  double range_sigma_metres = 0.03;  ///< the fixed range σ (metres), when noise_range_sigma is 0

  /** \brief Throws ParameterError naming the field as \a owner + "." + field (e.g.
    * "DepthPreprocessorConfig::bilateral.diameter"). */
  void validate (const std::string& owner = "BilateralFilterConfig") const;
};

struct DepthPreprocessorConfig
{
  BilateralFilterConfig bilateral;   ///< KinectFusion's filter: range σ 3 cm, spatial σ 4.5 px
  int pyramid_levels = 3;
  double min_depth = kMinDepth;      ///< measurements outside [min, max] are dropped
  double max_depth = kMaxDepth;
  double max_depth_jump = kPyramidDepthJump;  ///< relative depth step that breaks a 2×2 block average and the coarser levels' (±1 px) normals
  /// level 0's normals (§4.1.2: ±1 pixel); FusionPipeline gives tracking the segmentation's
  /// (segmentation::SurfacePreprocessingConfig::normals), so one normal map serves both
  NormalMapConfig normals;
  /// images narrower than this (pixels) get ±1 px normals at level 0 instead of `normals`
  /// (0: always `normals`). FusionPipeline sets 160 × normals.step: a span wider than 1/160
  /// of the image blurs normals across too much of each object for ICP's normal test
  /// (measured: ±4 px on a 160×120 orbit lost frames that ±1 and ±2 px tracked)
  int normals_min_width = 0;

  /** \brief Whether level 0 of an image \a width pixels wide gets `normals`. */
  bool levelZeroUsesNormals (int width) const { return width >= normals_min_width; }

  /** \brief The normals level 0 of an image \a width pixels wide gets. */
  NormalMapConfig
  levelZeroNormals (int width) const
  {
    return levelZeroUsesNormals (width) ? normals : NormalMapConfig{1, static_cast<float> (max_depth_jump)};
  }

  void validate () const;
};
/// The name before 0.2 (one config per class, named after it).
using DepthPreprocessingConfig [[deprecated ("renamed DepthPreprocessorConfig")]] = DepthPreprocessorConfig;

/** \brief One level of a vertex/normal pyramid, all maps of the level camera's size. */
struct PyramidLevel
{
  PinholeCamera camera;
  cv::Mat depth;      ///< CV_32F metres, 0 = invalid
  cv::Mat vertices;   ///< CV_32FC3 camera frame, NaN = invalid
  cv::Mat normals;    ///< CV_32FC3 camera frame, NaN = invalid
};

/** \brief Level 0 is the input resolution, each next level half the size. */
using FramePyramid = std::vector<PyramidLevel>;

/** \brief Turns a depth map into the filtered vertex and normal pyramid that tracking
  * aligns (§4.1.2): edge-preserving bilateral filter (OpenCV's, on metres, so the range σ
  * stops it from blurring across depth edges), then per level the vertex map V = K⁻¹u̇D
  * and central-difference normals. Coarser levels average 2×2 blocks of depth, leaving
  * out samples across a depth edge.
  */
class DepthPreprocessor
{
public:
  explicit DepthPreprocessor (const DepthPreprocessorConfig& config = DepthPreprocessorConfig ());

  const DepthPreprocessorConfig& getConfig () const { return config_; }

  void
  compute (const cv::Mat& depth, const PinholeCamera& camera, FramePyramid& pyramid) const;

private:
  DepthPreprocessorConfig config_;
};

/** \brief Smooths \a depth (CV_32F metres; 0, negative or NaN invalid) as \a config says:
  * noiseAdaptiveBilateral when its range σ follows the noise, else OpenCV's bilateral filter
  * on metres (invalid pixels enter it as 0, whose range kernel gives them no weight next to
  * a surface). Invalid pixels are 0 in \a filtered, whichever filter runs or none.
  */
void
bilateralFilterDepth (const cv::Mat& depth, const BilateralFilterConfig& config, cv::Mat& filtered);

/** \brief Bilateral filter of a depth map (CV_32F metres, ≤ 0 invalid) whose range σ is
  * \a range_sigma times the axial noise σ_z(z) of kinectAxialNoise at θ = 0: depth is
  * mapped to noise units u(z) = ∫ dz/σ_z, filtered with OpenCV's bilateral filter
  * (\a diameter, range σ \a range_sigma, spatial σ \a sigma_space pixels) and mapped
  * back. Invalid pixels stay 0 and take part in no average.
  */
void
noiseAdaptiveBilateral (const cv::Mat& depth, int diameter, float range_sigma, float sigma_space, cv::Mat& filtered);

/** \brief Depth at half resolution: each output pixel averages the valid samples of its
  * 2×2 block lying within \a max_jump × z of the block's nearest sample.
  */
void
downsampleDepth (const cv::Mat& depth, cv::Mat& half, float max_jump);

/** \brief Model maps (e.g. a raycast) at half resolution, averaging vertices and normals
  * the same way as downsampleDepth; normals renormalised.
  */
void
downsampleVertexNormalMaps (const cv::Mat& vertices, const cv::Mat& normals, cv::Mat& half_vertices,
                            cv::Mat& half_normals, float max_jump);

/** \brief Pyramid of model maps for tracking from full-resolution vertices and normals. */
void
buildModelPyramid (const cv::Mat& vertices, const cv::Mat& normals, const PinholeCamera& camera, int levels,
                   float max_jump, FramePyramid& pyramid);
}  // namespace reconstruction
}  // namespace cuefusion
