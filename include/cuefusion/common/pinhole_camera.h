// SPDX-License-Identifier: BSD-3-Clause
#pragma once

#include <cuefusion/common/fast_math.h>

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cmath>
#include <string>

namespace cuefusion
{
/** \brief Intrinsics of a pinhole camera (no distortion) and the image size.
  *
  * Pixel centres lie at integer coordinates: pixel (0, 0) covers [-0.5, 0.5]².
  * The camera frame is the usual vision frame: x right, y down, z forward.
  */
struct PinholeCamera
{
  double fx = 525.0;
  double fy = 525.0;
  double cx = 319.5;
  double cy = 239.5;
  int width = 640;
  int height = 480;

  PinholeCamera () = default;
  PinholeCamera (double fx_, double fy_, double cx_, double cy_, int width_, int height_)
    : fx (fx_), fy (fy_), cx (cx_), cy (cy_), width (width_), height (height_) {}

  /** \brief Continuous pixel coordinates (u, v) of a point in the camera frame (z > 0). */
  inline Eigen::Vector2f
  project (const Eigen::Vector3f& p) const
  {
    return {static_cast<float> (fx * p.x () / p.z () + cx), static_cast<float> (fy * p.y () / p.z () + cy)};
  }

  /** \brief Nearest pixel of a point; false when behind the camera or outside the image. */
  inline bool
  projectToPixel (const Eigen::Vector3f& p, int& u, int& v) const
  {
    if (!(p.z () > 0.f))
      return false;
    const Eigen::Vector2f uv = project (p);
    if (!(uv.x () > -1.f && uv.y () > -1.f && uv.x () < width && uv.y () < height))  // also keeps NaN and huge values out of the int conversion
      return false;
    u = fastFloor (uv.x () + 0.5f);
    v = fastFloor (uv.y () + 0.5f);
    return u >= 0 && v >= 0 && u < width && v < height;
  }

  /** \brief The 3D point seen at pixel (u, v) with z-depth \a depth (metres). */
  inline Eigen::Vector3f
  backProject (float u, float v, float depth) const
  {
    return {static_cast<float> ((u - cx) / fx) * depth, static_cast<float> ((v - cy) / fy) * depth, depth};
  }

  /** \brief The same camera at another resolution (e.g. 640×480 → 320×240).
    * Scales focal lengths by the size ratio and keeps the image borders fixed:
    * c' = (c + 0.5)·s − 0.5.
    */
  PinholeCamera
  scaled (int new_width, int new_height) const;

  /** \brief 3×3 matrix K. */
  Eigen::Matrix3d
  matrix () const;

  /** \brief Focal lengths in [1, 10^6] pixels, image size in [1, 65536] each way, principal
    * point within four image widths (heights) of the image's corner. */
  bool
  isValid () const;

  /** \brief Throws cuefusion::Error naming \a source when !isValid(). */
  void
  validate (const std::string& source) const;

  bool
  operator== (const PinholeCamera& other) const;
};

/** \brief A camera's image size and intrinsics in float, as the per-pixel and per-voxel
  * kernels (integration, the label update) read them.
  */
struct FloatIntrinsics
{
  int width = 0, height = 0;
  float fx = 0.f, fy = 0.f, cx = 0.f, cy = 0.f;

  FloatIntrinsics () = default;
  explicit FloatIntrinsics (const PinholeCamera& c)
    : width (c.width)
    , height (c.height)
    , fx (static_cast<float> (c.fx))
    , fy (static_cast<float> (c.fy))
    , cx (static_cast<float> (c.cx))
    , cy (static_cast<float> (c.cy))
  {
  }
};

/** \brief The Kinect axial noise model of Nguyen et al. 2012 at normal incidence,
  * σ_z(z, 0) = base + quadratic · (z − offset)²: its terms, and the one float form every
  * kernel evaluates (atNormalIncidence; avx2::kinectNoiseAtNormalIncidence in eight lanes,
  * the same operations in the same order, so scalar and vector paths agree bit for bit).
  * kinectAxialNoise adds the angular term in double.
  */
struct KinectNoiseModel
{
  static constexpr double base = 0.0012;
  static constexpr double quadratic = 0.0019;
  static constexpr double offset = 0.4;

  /** \brief σ_z(z, 0) in metres, in float: base + (quadratic · dz) · dz, dz = z − offset.
    * Called from code built for baseline x86-64 (no FMA), so the product is rounded before
    * the sum, as in the eight-lane version.
    */
  static float
  atNormalIncidence (float z)
  {
    const float dz = z - static_cast<float> (offset);
    return static_cast<float> (base) + static_cast<float> (quadratic) * dz * dz;
  }
};

/** \brief Kinect axial depth noise σ_z(z, θ) of Nguyen et al. 2012 (metres).
  * \param[in] z depth in metres
  * \param[in] theta angle between the viewing ray and the surface normal (radians)
  *
  * σ_z = 0.0012 + 0.0019 (z − 0.4)² + 0.0001/√z · θ²/(π/2 − θ)²; θ is clamped just below
  * π/2 so grazing angles give a large but finite value.
  */
double
kinectAxialNoise (double z, double theta);
/** \brief Camera-to-world pose (x right, y down, z forward) at \a eye looking at
  * \a target, with \a up (default world z) pointing up in the image; the view must not
  * be along \a up. (The generator's cameras and the off-screen renders use it.)
  */
Eigen::Isometry3d
lookAt (const Eigen::Vector3d& eye, const Eigen::Vector3d& target, const Eigen::Vector3d& up = Eigen::Vector3d::UnitZ ());
}  // namespace cuefusion
