#pragma once

#include <cuefusion/common/pinhole_camera.h>

#include <opencv2/core.hpp>

#include <vector>

namespace cuefusion
{
namespace reconstruction
{
/** \brief Depth preprocessing for tracking (§4.1.2). */
struct DepthPreprocessorConfig
{
  bool bilateral_filter = true;
  int bilateral_diameter = 5;        ///< pixels
  double sigma_depth = 0.03;         ///< range σ of the bilateral filter (metres)
  /// > 0: the range σ follows the sensor noise instead, this many σ_z(z) (noiseAdaptiveBilateral,
  /// the geometric segmentation's smoothing); FusionPipeline sets it so one filter serves both
  double noise_range_sigma = 0.0;
  double sigma_space = 4.5;          ///< spatial σ (pixels), KinectFusion's values
  int pyramid_levels = 3;
  double min_depth = 0.1;            ///< measurements outside [min, max] are dropped
  double max_depth = 5.0;
  double max_depth_jump = 0.05;      ///< relative depth step that breaks a normal / block average

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
