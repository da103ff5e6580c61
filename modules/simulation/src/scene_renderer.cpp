// SPDX-License-Identifier: BSD-3-Clause
#include <cuefusion/common/hash.h>
#include <cuefusion/common/parallel.h>
#include <cuefusion/common/pinhole_camera.h>
#include <cuefusion/simulation/scene_renderer.h>

#include <cmath>
#include <limits>
#include <random>

namespace cuefusion
{
namespace simulation
{
std::uint64_t
mixSeed (std::uint64_t seed, std::uint64_t counter)
{
  return splitMix64 (seed + 0x9e3779b97f4a7c15ULL * (counter + 1));
}

SceneRenderer::SceneRenderer (const SyntheticScene& scene) : scene_ (scene)
{
  for (std::uint32_t i = 0; i < scene_.objects.size (); ++i)
  {
    class_of_.push_back (scene_.classIdOf (scene_.objects[i]));
    for (std::uint32_t k = 0; k < scene_.objects[i].parts.size (); ++k)
    {
      every_part_.push_back (static_cast<std::uint32_t> (parts_.size ()));
      const double yaw = scene_.objects[i].parts[k].yaw;
      parts_.push_back ({i, k, std::cos (yaw), std::sin (yaw)});
    }
  }
}

std::uint16_t
SceneRenderer::castRay (const Eigen::Vector3d& origin, const Eigen::Vector3d& dir, double& t,
                        Eigen::Vector3d& normal) const
{
  return castRayAmong (origin, dir, every_part_, t, normal);
}

std::uint16_t
SceneRenderer::castRayAmong (const Eigen::Vector3d& origin, const Eigen::Vector3d& dir,
                             const std::vector<std::uint32_t>& candidates, double& t, Eigen::Vector3d& normal) const
{
  std::uint16_t hit_id = 0;
  t = std::numeric_limits<double>::infinity ();
  for (const std::uint32_t k : candidates)
  {
    const SceneObject& o = scene_.objects[parts_[k].object];
    const Primitive& prim = o.parts[parts_[k].part];
    // Cull by bounding sphere before the exact test.
    const Eigen::Vector3d oc = prim.center - origin;
    const double along = oc.dot (dir);
    const double r = prim.boundingRadius ();
    if (along + r < 0.0 || oc.squaredNorm () - along * along > r * r || along - r > t)
      continue;
    double ti;
    Eigen::Vector3d ni;
    if (prim.intersect (origin, dir, 1e-6, parts_[k].cos_yaw, parts_[k].sin_yaw, ti, ni) && ti < t)
    {
      t = ti;
      normal = ni;
      hit_id = o.id;
    }
  }
  return hit_id;
}

void
SceneRenderer::partsInCone (const Eigen::Vector3d& origin, const Eigen::Vector3d& axis, double half_angle,
                            std::vector<std::uint32_t>& candidates) const
{
  // A ray at angle φ to the direction of a sphere's centre (distance d, radius r < d)
  // meets it only when φ ≤ β = asin (r / d); the rays of the cone are within half_angle
  // α of the axis, so a sphere whose centre is more than α + β off the axis (its cosine
  // below cos (α + β) = cos α cos β − sin α sin β; α + β ≤ π here) is missed by all of
  // them. The small margin keeps rounding on the safe side.
  constexpr double kMargin = 1e-6;
  const double cos_a = std::cos (half_angle), sin_a = std::sin (half_angle);
  candidates.clear ();
  for (std::uint32_t k = 0; k < parts_.size (); ++k)
  {
    const Primitive& prim = scene_.objects[parts_[k].object].parts[parts_[k].part];
    const Eigen::Vector3d oc = prim.center - origin;
    const double d = oc.norm (), r = prim.boundingRadius ();
    if (d > r)
    {
      const double sin_b = r / d, cos_b = std::sqrt (1.0 - sin_b * sin_b);
      if (oc.dot (axis) / d < cos_a * cos_b - sin_a * sin_b - kMargin)
        continue;
    }
    candidates.push_back (k);
  }
}

cv::Vec3b
SceneRenderer::shade (const SceneObject& object, const Eigen::Vector3d& p, const Eigen::Vector3d& n) const
{
  static const Eigen::Vector3d light = Eigen::Vector3d (0.3, 0.5, 1.0).normalized ();
  double k = 0.45 + 0.55 * std::max (0.0, n.dot (light));
  if (object.checker && (static_cast<long> (std::floor (p.x () / 0.25)) + static_cast<long> (std::floor (p.y () / 0.25))) % 2)
    k *= 0.75;
  if (object.print)
  {
    // Two scales of cubes of space, each a grey level from a hash of its cell and the
    // object (the same point looks the same from every view).
    const auto level = [&] (double cell, std::uint64_t salt) {
      const auto c = [&] (double x) { return static_cast<std::uint64_t> (static_cast<std::int64_t> (std::floor (x / cell))); };
      const std::uint64_t h = splitMix64 (c (p.x ()) * 0x9E3779B97F4A7C15ull ^ splitMix64 (c (p.y ()) + salt) ^
                                          splitMix64 (c (p.z ()) * 0xC2B2AE3D27D4EB4Full + object.id));
      return static_cast<double> (h >> 40) / static_cast<double> (1ull << 24);
    };
    k *= 0.4 + 0.35 * level (0.05, 1) + 0.25 * level (0.015, 2);
  }
  auto channel = [k] (std::uint8_t c) { return static_cast<std::uint8_t> (std::min (255.0, std::round (c * k))); };
  return cv::Vec3b (channel (object.rgb[2]), channel (object.rgb[1]), channel (object.rgb[0]));
}

namespace
{
/** \brief Stereo's foreground fattening: a pixel within \a radius pixels along x (the
  * baseline) of a surface more than 5 % nearer takes that surface's measured depth, as
  * block matching assigns a window straddling an edge to the nearer side. The surfaces
  * are compared by their exact depth \a exact, so that noise alone fattens nothing. */
void
fattenEdges (cv::Mat& depth, const cv::Mat& exact, int radius)
{
  const cv::Mat measured = depth.clone ();
  for (int v = 0; v < depth.rows; ++v)
  {
    const float* z = exact.ptr<float> (v);
    const float* in = measured.ptr<float> (v);
    float* out = depth.ptr<float> (v);
    for (int u = 0; u < depth.cols; ++u)
    {
      if (!(z[u] > 0.f))
        continue;
      int nearest = -1;
      for (int k = std::max (0, u - radius); k <= std::min (depth.cols - 1, u + radius); ++k)
        if (z[k] > 0.f && z[k] < 0.95f * z[u] && (nearest < 0 || z[k] < z[nearest]))
          nearest = k;
      if (nearest >= 0 && in[nearest] > 0.f)
        out[u] = in[nearest];
    }
  }
}
}  // namespace

RenderedView
SceneRenderer::render (const PinholeCamera& camera, const Eigen::Isometry3d& pose, const DepthNoiseConfig& noise,
                       std::uint64_t noise_seed) const
{
  RenderedView view;
  view.depth = cv::Mat (camera.height, camera.width, CV_32F, cv::Scalar (0.f));
  view.color = cv::Mat (camera.height, camera.width, CV_8UC3, cv::Scalar (0, 0, 0));
  view.instance = cv::Mat (camera.height, camera.width, CV_16U, cv::Scalar (0));
  view.class_ids = cv::Mat (camera.height, camera.width, CV_16U, cv::Scalar (0));
  view.normals = cv::Mat (camera.height, camera.width, CV_32FC3, cv::Scalar (0, 0, 0));
  view.exact_depth = cv::Mat (camera.height, camera.width, CV_32F, cv::Scalar (0.f));
  const Eigen::Matrix3d rotation = pose.rotation ();
  const Eigen::Vector3d origin = pose.translation ();
  const double deg = 3.14159265358979323846 / 180.0;
  const bool stereo_fattening = noise.enabled && noise.sensor == DepthSensor::RealSense && noise.edge_fattening_px > 0;

  const auto rayAt = [&] (double u, double v) {
    return (rotation * Eigen::Vector3d ((u - camera.cx) / camera.fx, (v - camera.cy) / camera.fy, 1.0)).normalized ();
  };
  const int tile_columns = (camera.width + kCullTile - 1) / kCullTile;

  parallelForChunks (camera.height, kCullTile, [&] (int, int begin, int end) {
    // The parts each tile of this row of tiles can see: the cone around the ray through
    // the tile's centre that holds the rays through its four corner pixels (the pixels
    // between lie on the image plane inside the corners' hull, so inside the cone).
    std::vector<std::vector<std::uint32_t>> candidates (tile_columns);
    for (int c = 0; c < tile_columns; ++c)
    {
      const int u0 = c * kCullTile, u1 = std::min (camera.width, u0 + kCullTile) - 1;
      const Eigen::Vector3d axis = rayAt (0.5 * (u0 + u1), 0.5 * (begin + end - 1));
      double half_angle = 0.0;
      for (const Eigen::Vector3d& corner : {rayAt (u0, begin), rayAt (u1, begin), rayAt (u0, end - 1), rayAt (u1, end - 1)})
        half_angle = std::max (half_angle, std::atan2 (corner.cross (axis).norm (), corner.dot (axis)));
      partsInCone (origin, axis, half_angle, candidates[c]);
    }
    for (int v = begin; v < end; ++v)
    {
      // One random stream per row keeps the noise independent of the thread count.
      std::mt19937_64 rng (mixSeed (noise_seed, static_cast<std::uint64_t> (v)));
      std::normal_distribution<double> gauss (0.0, 1.0);
      std::uniform_real_distribution<double> uniform (0.0, 1.0);
      for (int u = 0; u < camera.width; ++u)
      {
        const Eigen::Vector3d dir = rayAt (u, v);
        double t;
        Eigen::Vector3d n;
        const std::uint16_t id = castRayAmong (origin, dir, candidates[u / kCullTile], t, n);
        if (id == 0)
          continue;
        const SceneObject& object = scene_.objects[id - 1u];
        const Eigen::Vector3d p = origin + t * dir;
        view.instance.at<std::uint16_t> (v, u) = id;
        view.class_ids.at<std::uint16_t> (v, u) = class_of_[id - 1u];
        view.color.at<cv::Vec3b> (v, u) = shade (object, p, n);
        const Eigen::Vector3d n_cam = rotation.transpose () * n;
        view.normals.at<cv::Vec3f> (v, u) = cv::Vec3f (static_cast<float> (n_cam.x ()), static_cast<float> (n_cam.y ()),
                                                       static_cast<float> (n_cam.z ()));
        double z = (rotation.transpose () * (p - origin)).z ();
        view.exact_depth.at<float> (v, u) = static_cast<float> (z);
        if (noise.enabled)
        {
          const double incidence = std::acos (std::min (1.0, std::abs (n.dot (dir))));
          const double start = noise.dropout_start_deg * deg, stop = noise.max_incidence_deg * deg;
          if (incidence >= stop || (incidence > start && uniform (rng) < (incidence - start) / (stop - start)))
            continue;
          if (noise.sensor == DepthSensor::RealSense)
          {
            const cv::Vec3b bgr = view.color.at<cv::Vec3b> (v, u);
            const double luma = 0.114 * bgr[0] + 0.587 * bgr[1] + 0.299 * bgr[2];
            if (uniform (rng) < noise.speckle || (luma < noise.dark_luminance && uniform (rng) < noise.dark_dropout))
              continue;
            z += gauss (rng) * stereoAxialNoise (z, camera.fx * 640.0 / camera.width, noise);
          }
          else
            z += gauss (rng) * kinectAxialNoise (z, incidence);
          if (z < noise.min_depth || z > noise.max_depth)
            continue;
        }
        view.depth.at<float> (v, u) = static_cast<float> (z);
      }
    }
  });
  if (stereo_fattening)
    fattenEdges (view.depth, view.exact_depth, noise.edge_fattening_px);
  return view;
}

double
stereoAxialNoise (double z, double fx, const DepthNoiseConfig& noise)
{
  return z * z * noise.stereo_subpixel / (fx * noise.stereo_baseline);
}
}  // namespace simulation
}  // namespace cuefusion
