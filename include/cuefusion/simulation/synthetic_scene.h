// SPDX-License-Identifier: BSD-3-Clause
#pragma once

#include <cuefusion/common/pinhole_camera.h>

#include <Eigen/Geometry>

#include <array>
#include <cstdint>
#include <string>
#include <vector>

namespace cuefusion
{
namespace simulation
{
/** \brief An analytic solid of a synthetic scene: box, upright cylinder or sphere.
  * All have a centre; boxes and cylinders may be turned by a yaw about world z.
  */
struct Primitive
{
  enum class Type
  {
    Box,
    Cylinder,
    Sphere
  };
  Type type = Type::Box;
  Eigen::Vector3d center = Eigen::Vector3d::Zero ();
  Eigen::Vector3d half_size = Eigen::Vector3d::Constant (0.5);  ///< box half extents; cylinder (r, r, h/2); sphere (r, r, r)
  double yaw = 0.0;                                               ///< radians about world z

  /** \brief Nearest hit of origin + t·dir with t > t_min; outward unit normal in world. */
  bool intersect (const Eigen::Vector3d& origin, const Eigen::Vector3d& dir, double t_min, double& t,
                  Eigen::Vector3d& normal) const;
  /** \brief intersect with cos (yaw) and sin (yaw) given (a renderer casting many rays
    * computes them once per part). */
  bool intersect (const Eigen::Vector3d& origin, const Eigen::Vector3d& dir, double t_min, double cos_yaw, double sin_yaw,
                  double& t, Eigen::Vector3d& normal) const;
  /** \brief True when \a p lies inside the solid grown by \a margin. */
  bool contains (const Eigen::Vector3d& p, double margin) const;
  /** \brief Points on the surface, about \a spacing apart. */
  void sampleSurface (double spacing, std::vector<Eigen::Vector3d>& points) const;
  /** \brief Radius of a sphere around center holding the solid (for culling). */
  double boundingRadius () const { return half_size.norm (); }

  Eigen::Vector3d toLocal (const Eigen::Vector3d& p) const;
  Eigen::Vector3d fromLocal (const Eigen::Vector3d& p) const;
  Eigen::Vector3d directionFromLocal (const Eigen::Vector3d& d) const;
};

/** \brief One object instance: one or more primitives sharing an id, class and colour. */
struct SceneObject
{
  std::uint16_t id = 0;                      ///< instance id, 1-based in file order
  std::string name;
  std::string class_name;
  std::array<std::uint8_t, 3> rgb{{128, 128, 128}};
  bool detectable = true;                    ///< a network would report it (not floor/walls)
  bool checker = false;                      ///< checkerboard texture (floors)
  /// printed texture: grey levels of 5 cm and 1.5 cm cubes of space (a print, wood, a
  /// poster: what features are found on in real scenes; flat shading has almost none)
  bool print = false;
  std::vector<Primitive> parts;

  /** \brief Axis-aligned box around every part (world). */
  Eigen::AlignedBox3d bounds () const;
};

/** \brief Smooth orbit of the camera around a target, looking at it. */
struct OrbitTrajectory
{
  Eigen::Vector3d target = Eigen::Vector3d (0, 0, 0.75);
  double radius = 1.3;
  double height = 0.6;        ///< camera height above the target
  double start_deg = 200.0;   ///< azimuth at the first frame
  double sweep_deg = 70.0;    ///< azimuth travelled over the sequence
  double bob = 0.05;          ///< vertical sway amplitude (m)

  /** \brief Camera-to-world pose (x right, y down, z forward) at s ∈ [0, 1]. */
  Eigen::Isometry3d poseAt (double s) const;
};

/** \brief A point of a hand-held camera path: where the camera is and the point it looks at. */
struct CameraWaypoint
{
  Eigen::Vector3d eye = Eigen::Vector3d::Zero ();
  Eigen::Vector3d target = Eigen::Vector3d::UnitX ();
};

/** \brief A hand-held camera's path through waypoints: the eye and the point looked at each
  * follow a Catmull-Rom spline through theirs (it passes through every waypoint, with no
  * kinks), the waypoints passed at equal steps of s, so the camera slows where they are near.
  */
struct CameraPath
{
  std::vector<CameraWaypoint> waypoints;

  /** \brief Camera-to-world pose at s ∈ [0, 1]; needs two waypoints or more. */
  Eigen::Isometry3d poseAt (double s) const;
};

/** \brief A procedural scene read from a small text file (data/scenes/NAME.scene):
  *
  * \code
  * scene tabletop
  * camera 640 480 525 525 319.5 239.5            # width height fx fy cx cy
  * trajectory target=0,0,0.75 radius=1.3 height=0.6 start=200 sweep=70 bob=0.05
  * object table class=dining_table color=150,110,70
  *   box center=0,0,0.72 size=1.2,0.8,0.04 yaw=0
  * object mug class=cup color=200,40,40
  *   cylinder center=0.2,0.1,0.79 radius=0.04 height=0.10
  * object ball class=sports_ball color=40,40,200
  *   sphere center=-0.3,0,0.8 radius=0.06
  * \endcode
  * A camera path through waypoints replaces the orbit (two or more lines, in order):
  * \code
  * waypoint eye=1.0,1.2,1.5 target=3.0,2.5,0.9
  * \endcode
  * "_" in class names stands for a space. "detectable=no" marks stuff a detector does
  * not report (floor, walls), "texture=checker" a checkerboard, "texture=print" a printed pattern
  * (SceneObject::print). World z is up.
  */
struct SyntheticScene
{
  std::string name;
  PinholeCamera camera;
  OrbitTrajectory trajectory;
  CameraPath path;               ///< when it has waypoints, the camera follows it instead of the orbit
  std::vector<SceneObject> objects;

  /** \brief Camera-to-world pose at s ∈ [0, 1] of the sequence: along the path when it has
    * waypoints, else on the orbit. */
  Eigen::Isometry3d cameraPoseAt (double s) const;

  /** \brief Distinct class names in order of first appearance; class id = index + 1. */
  std::vector<std::string> classNames () const;
  std::uint16_t classIdOf (const SceneObject& object) const;
  const SceneObject* objectById (std::uint16_t id) const;

  static SyntheticScene parse (const std::string& text, const std::string& source);
  /** \brief The scene as the text parse() reads (numbers to 6 significant digits). */
  std::string text () const;
  static SyntheticScene load (const std::string& path);
};

/** \brief Resolves "NAME" to <scenes_dir>/NAME.scene, or takes an existing file path. */
std::string
resolveScenePath (const std::string& name_or_file, const std::string& scenes_dir);

/** \brief <dataDirectory()>/scenes: the installed or the source tree's data/scenes, or $CUEFUSION_DATA_DIR/scenes. */
std::string
defaultScenesDir ();
}  // namespace simulation
}  // namespace cuefusion
