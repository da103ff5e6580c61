// SPDX-License-Identifier: BSD-3-Clause
#pragma once

#include <cuefusion/simulation/synthetic_scene.h>

#include <opencv2/core.hpp>

#include <cstdint>
#include <vector>

namespace cuefusion
{
namespace simulation
{
/** \brief The depth sensor a rendered view imitates. */
enum class DepthSensor
{
  Kinect,    ///< structured light (Kinect v1, Asus Xtion): kinectAxialNoise, grazing-angle dropout
  RealSense  ///< active stereo (RealSense D400-like): noise growing with z², speckle, edge fattening, holes on dark surfaces
};

/** \brief Sensor imperfections added to rendered depth (off by default: exact depth). */
struct DepthNoiseConfig
{
  bool enabled = false;
  DepthSensor sensor = DepthSensor::Kinect;
  double dropout_start_deg = 70.0;   ///< incidence angle where pixels start to go missing
  double max_incidence_deg = 80.0;   ///< beyond this every pixel is missing
  double min_depth = 0.3;            ///< sensor range (m); outside it depth is 0
  double max_depth = 8.0;
  // RealSense only. Stereo depth error σ_z = z² · subpixel / (f · baseline) (Intel's
  // D400 figure, RMS subpixel 0.08 with its projector; f the camera's focal length in
  // pixels at 640 pixels across, the sensor's depth resolution, whatever size is rendered).
  double stereo_baseline = 0.05;     ///< metres (D435: 50 mm)
  double stereo_subpixel = 0.08;     ///< RMS disparity error (pixels)
  double speckle = 0.01;             ///< probability a pixel has no depth (failed match)
  /// a background pixel within this many pixels (along the baseline, x) of a surface
  /// more than 5 % nearer takes that surface's depth: stereo's foreground fattening
  int edge_fattening_px = 2;
  double dark_luminance = 40.0;      ///< surfaces shaded darker than this (0–255 luma) ...
  double dark_dropout = 0.7;         ///< ... lose this share of their pixels (IR absorbed, no match)
};

/** \brief σ_z of the RealSense-like model at depth \a z for a focal length of \a fx pixels
  * at 640 pixels across. */
double
stereoAxialNoise (double z, double fx, const DepthNoiseConfig& noise);

/** \brief What one view of a scene looks like, with exact truth. */
struct RenderedView
{
  cv::Mat depth;       ///< CV_32F z-depth in metres, 0 where no surface (or dropped)
  cv::Mat color;       ///< CV_8UC3 BGR, Lambertian shading under a fixed light
  cv::Mat instance;    ///< CV_16U object id of the visible surface (0 = none)
  cv::Mat class_ids;   ///< CV_16U class id of the visible surface (0 = none)
  cv::Mat normals;     ///< CV_32FC3 camera-frame unit normal of the visible surface
  cv::Mat exact_depth; ///< CV_32F z-depth of the visible surface before any noise or dropout (0 = none)
};

/** \brief Ray-casts a SyntheticScene through a pinhole camera, one ray per pixel centre.
  * The image is cast in tiles of kCullTile × kCullTile pixels: each tile's rays are tested only
  * against the parts whose bounding sphere the tile's cone of rays can meet (a
  * conservative cull, so the image is the one casting every ray against every part
  * gives). Rows of tiles run in parallel on the project's thread pool (common/parallel.h).
  */
class SceneRenderer
{
public:
  explicit SceneRenderer (const SyntheticScene& scene);

  /** \brief Renders the view from camera-to-world \a pose. \a noise_seed seeds the noise
    * (only used when noise.enabled), so a frame renders the same on every run.
    */
  RenderedView render (const PinholeCamera& camera, const Eigen::Isometry3d& pose,
                       const DepthNoiseConfig& noise = DepthNoiseConfig (), std::uint64_t noise_seed = 0) const;

  /** \brief Nearest surface along a world ray: object id (0 = none), distance t, world normal. */
  std::uint16_t castRay (const Eigen::Vector3d& origin, const Eigen::Vector3d& dir, double& t,
                         Eigen::Vector3d& normal) const;

  /** \brief Shaded colour (R, G, B) of object \a id at world point \a p with normal \a n. */
  cv::Vec3b shade (const SceneObject& object, const Eigen::Vector3d& p, const Eigen::Vector3d& n) const;

  /** \brief Side of the square tiles of pixels render culls the scene's parts for. */
  static constexpr int kCullTile = 8;

private:
  /** \brief One part of one object, by index (the renderer may be copied). */
  struct PartIndex
  {
    std::uint32_t object;
    std::uint32_t part;
    double cos_yaw, sin_yaw;  ///< of the part's yaw, for Primitive::intersect
  };
  /** \brief castRay over the parts \a candidates lists (indices into parts_, in scene order). */
  std::uint16_t castRayAmong (const Eigen::Vector3d& origin, const Eigen::Vector3d& dir,
                              const std::vector<std::uint32_t>& candidates, double& t, Eigen::Vector3d& normal) const;
  /** \brief The parts (indices into parts_, in order) whose bounding sphere a ray from
    * \a origin within \a half_angle radians of the unit direction \a axis can meet. */
  void partsInCone (const Eigen::Vector3d& origin, const Eigen::Vector3d& axis, double half_angle,
                    std::vector<std::uint32_t>& candidates) const;

  SyntheticScene scene_;  // a copy: small, and no lifetime ties to the caller
  std::vector<std::uint16_t> class_of_;   ///< object index → class id
  std::vector<PartIndex> parts_;          ///< every object's parts, in scene order
  std::vector<std::uint32_t> every_part_; ///< 0 … parts_.size () − 1
};

/** \brief 64-bit mix of a seed and a counter (SplitMix64), for per-frame random streams
  * that do not depend on the order frames are generated in.
  */
std::uint64_t
mixSeed (std::uint64_t seed, std::uint64_t counter);
}  // namespace simulation
}  // namespace cuefusion
