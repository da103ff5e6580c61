// SPDX-License-Identifier: BSD-3-Clause
#include <cuefusion/common/exceptions.h>
#include <cuefusion/common/label_colors.h>
#include <cuefusion/common/pinhole_camera.h>
#include <cuefusion/visualization/mesh_rasterizer.h>

#include <algorithm>
#include <cmath>
#include <functional>

namespace cuefusion
{
namespace visualization
{
void
MeshRasterizerConfig::validate () const
{
  if (!(near_plane > 0.f))
    throw ParameterError ("MeshRasterizerConfig::near_plane", "must be positive");
}

MeshRasterizer::MeshRasterizer (const MeshRasterizerConfig& config) : config_ (config)
{
  config_.validate ();
}

MeshView
MeshRasterizer::render (const io::TriangleMesh& mesh, const PinholeCamera& camera, const Eigen::Isometry3d& pose) const
{
  if (camera.width <= 0 || camera.height <= 0)
    throw ParameterError ("MeshRasterizer::render camera", "image size must be positive");
  MeshView view;
  view.labels = cv::Mat::zeros (camera.height, camera.width, CV_32S);
  view.depth = cv::Mat::zeros (camera.height, camera.width, CV_32F);
  view.image = cv::Mat (camera.height, camera.width, CV_8UC3, cv::Scalar (config_.background[0], config_.background[1], config_.background[2]));

  const Eigen::Isometry3f world_to_camera = pose.inverse ().cast<float> ();
  std::vector<Eigen::Vector3f> pc (mesh.vertices.size ());
  for (std::size_t i = 0; i < pc.size (); ++i)
    pc[i] = world_to_camera * mesh.vertices[i];
  const bool have_labels = !mesh.labels.empty () && config_.color_by_label;
  const bool have_colors = !mesh.colors.empty ();
  const bool have_normals = mesh.normals.size () == mesh.vertices.size ();
  const Eigen::Matrix3f rotation = world_to_camera.linear ();
  const auto fx = static_cast<float> (camera.fx), fy = static_cast<float> (camera.fy);
  const auto cx = static_cast<float> (camera.cx), cy = static_cast<float> (camera.cy);

  for (const Eigen::Vector3i& t : mesh.triangles)
  {
    const Eigen::Vector3f& a = pc[static_cast<std::size_t> (t[0])];
    const Eigen::Vector3f& b = pc[static_cast<std::size_t> (t[1])];
    const Eigen::Vector3f& c = pc[static_cast<std::size_t> (t[2])];
    if (a.z () < config_.near_plane || b.z () < config_.near_plane || c.z () < config_.near_plane)
      continue;
    const Eigen::Vector2f pa (fx * a.x () / a.z () + cx, fy * a.y () / a.z () + cy);
    const Eigen::Vector2f pb (fx * b.x () / b.z () + cx, fy * b.y () / b.z () + cy);
    const Eigen::Vector2f pcc (fx * c.x () / c.z () + cx, fy * c.y () / c.z () + cy);
    const float area = (pb - pa).x () * (pcc - pa).y () - (pb - pa).y () * (pcc - pa).x ();
    if (std::abs (area) < 1e-12f)
      continue;
    const int u0 = std::max (0, static_cast<int> (std::ceil (std::min ({pa.x (), pb.x (), pcc.x ()}))));
    const int u1 = std::min (camera.width - 1, static_cast<int> (std::floor (std::max ({pa.x (), pb.x (), pcc.x ()}))));
    const int v0 = std::max (0, static_cast<int> (std::ceil (std::min ({pa.y (), pb.y (), pcc.y ()}))));
    const int v1 = std::min (camera.height - 1, static_cast<int> (std::floor (std::max ({pa.y (), pb.y (), pcc.y ()}))));
    if (u0 > u1 || v0 > v1)
      continue;
    // Headlight Lambert shading (two-sided unless culled) and culling from the surface's
    // normal: the mean of the corners' normals where the mesh has them, else the face's.
    // A TSDF mesh's vertex normals are the field's gradient, smooth where the faces of a
    // noisy far wall are not: shaded by its face normals such a wall came out as grain.
    Eigen::Vector3f normal = (b - a).cross (c - a).normalized ();
    if (have_normals)
    {
      const Eigen::Vector3f mean = rotation * (mesh.normals[static_cast<std::size_t> (t[0])] + mesh.normals[static_cast<std::size_t> (t[1])] +
                                               mesh.normals[static_cast<std::size_t> (t[2])]);
      if (mean.squaredNorm () > 1e-12f)
        normal = mean.normalized ();
    }
    if (config_.cull_back_faces && normal.dot (a) > 0.f)
      continue;
    const Eigen::Vector3f centre = ((a + b + c) / 3.f).normalized ();
    const float shade = 0.35f + 0.65f * std::abs (normal.dot (centre));
    const float inv_area = 1.f / area;
    const float iza = 1.f / a.z (), izb = 1.f / b.z (), izc = 1.f / c.z ();
    for (int v = v0; v <= v1; ++v)
      for (int u = u0; u <= u1; ++u)
      {
        const Eigen::Vector2f p (static_cast<float> (u), static_cast<float> (v));
        // Barycentric weights from signed sub-areas; inside when all agree with the area's sign.
        const float wa = ((pb - p).x () * (pcc - p).y () - (pb - p).y () * (pcc - p).x ()) * inv_area;
        const float wb = ((pcc - p).x () * (pa - p).y () - (pcc - p).y () * (pa - p).x ()) * inv_area;
        const float wc = 1.f - wa - wb;
        if (wa < 0.f || wb < 0.f || wc < 0.f)
          continue;
        const float z = 1.f / (wa * iza + wb * izb + wc * izc);
        float& zbuffer = view.depth.at<float> (v, u);
        if (zbuffer > 0.f && zbuffer <= z)
          continue;
        zbuffer = z;
        const int corner = wa >= wb && wa >= wc ? 0 : (wb >= wc ? 1 : 2);
        const auto vertex = static_cast<std::size_t> (t[corner]);
        cv::Vec3b bgr (160, 160, 160);
        if (have_labels)
        {
          const std::uint32_t label = mesh.labels[vertex];
          view.labels.at<std::int32_t> (v, u) = static_cast<std::int32_t> (label);
          const cv::Vec3b rgb = segmentColor (label);
          bgr = cv::Vec3b (rgb[2], rgb[1], rgb[0]);
        }
        else
        {
          if (!mesh.labels.empty ())
            view.labels.at<std::int32_t> (v, u) = static_cast<std::int32_t> (mesh.labels[vertex]);
          if (have_colors)
          {
            const auto& rgb = mesh.colors[vertex];
            bgr = cv::Vec3b (rgb[2], rgb[1], rgb[0]);
          }
        }
        view.image.at<cv::Vec3b> (v, u) = cv::Vec3b (cv::saturate_cast<std::uint8_t> (bgr[0] * shade),
                                                     cv::saturate_cast<std::uint8_t> (bgr[1] * shade),
                                                     cv::saturate_cast<std::uint8_t> (bgr[2] * shade));
      }
  }
  return view;
}

std::vector<Eigen::Isometry3d, Eigen::aligned_allocator<Eigen::Isometry3d>>
orbitViews (const io::TriangleMesh& mesh, const PinholeCamera& camera, int views, const Eigen::Vector3d& up_direction,
            const std::set<std::uint32_t>& focus)
{
  if (views < 1)
    throw ParameterError ("orbitViews views", "must be at least 1");
  if (mesh.vertices.empty ())
    throw Error ("orbitViews", "the mesh has no vertices");
  // The box of the labelled vertices (all when none is), from the 2nd to the 98th
  // percentile on each axis: a few stray surfaces far off (a speck of wall through a
  // window, a noise patch metres away) would otherwise set the framing and leave the map
  // a small blot in the middle of the render.
  std::vector<float> coordinates[3];
  const auto gather = [&] (const std::function<bool (std::uint32_t)>& chosen) {
    for (std::size_t i = 0; i < mesh.vertices.size () && i < mesh.labels.size (); ++i)
      if (mesh.labels[i] != 0 && chosen (mesh.labels[i]))
        for (int axis = 0; axis < 3; ++axis)
          coordinates[axis].push_back (mesh.vertices[i][axis]);
  };
  if (!focus.empty ())
    gather ([&focus] (std::uint32_t label) { return focus.count (label) > 0; });
  if (coordinates[0].empty ())
    gather ([] (std::uint32_t) { return true; });
  if (coordinates[0].empty ())
    for (const Eigen::Vector3f& v : mesh.vertices)
      for (int axis = 0; axis < 3; ++axis)
        coordinates[axis].push_back (v[axis]);
  Eigen::AlignedBox3f box;
  for (int axis = 0; axis < 3; ++axis)
  {
    std::vector<float>& c = coordinates[axis];
    const auto at = [&] (double share) {
      const auto k = static_cast<std::size_t> (share * static_cast<double> (c.size () - 1) + 0.5);
      std::nth_element (c.begin (), c.begin () + static_cast<std::ptrdiff_t> (k), c.end ());
      return c[k];
    };
    box.min ()[axis] = at (0.02);
    box.max ()[axis] = at (0.98);
  }
  const Eigen::Vector3d centre = box.center ().cast<double> ();
  const double radius = std::max (0.05, 0.5 * static_cast<double> (box.diagonal ().norm ()));
  const double half_fov = std::min (std::atan (0.5 * camera.width / camera.fx), std::atan (0.5 * camera.height / camera.fy));
  const double distance = radius / std::sin (half_fov) * 1.05;
  const double elevation = 30.0 * M_PI / 180.0;
  const Eigen::Vector3d up = up_direction.normalized ();
  // Two directions spanning the plane orthogonal to up.
  const Eigen::Vector3d a = up.unitOrthogonal ();
  const Eigen::Vector3d b = up.cross (a);
  std::vector<Eigen::Isometry3d, Eigen::aligned_allocator<Eigen::Isometry3d>> poses;
  for (int k = 0; k < views; ++k)
  {
    const double azimuth = 2.0 * M_PI * k / views - M_PI / 2.0;
    const Eigen::Vector3d eye =
      centre + distance * (std::cos (elevation) * (std::cos (azimuth) * a + std::sin (azimuth) * b) + std::sin (elevation) * up);
    poses.push_back (lookAt (eye, centre, up));
  }
  return poses;
}
std::vector<Eigen::Isometry3d, Eigen::aligned_allocator<Eigen::Isometry3d>>
cameraViews (const std::vector<Eigen::Isometry3d, Eigen::aligned_allocator<Eigen::Isometry3d>>& poses, int views)
{
  if (views < 1)
    throw ParameterError ("cameraViews views", "must be at least 1");
  if (poses.empty ())
    throw ParameterError ("cameraViews poses", "must hold at least one camera pose");
  std::vector<Eigen::Isometry3d, Eigen::aligned_allocator<Eigen::Isometry3d>> out;
  const double last = static_cast<double> (poses.size () - 1);
  for (int k = 0; k < views; ++k)
  {
    const double at = views == 1 ? 0.5 * last : last * k / (views - 1);
    out.push_back (poses[static_cast<std::size_t> (std::lround (at))]);
  }
  return out;
}

Eigen::Vector3d
upFromCameras (const std::vector<Eigen::Isometry3d, Eigen::aligned_allocator<Eigen::Isometry3d>>& poses)
{
  Eigen::Vector3d sum = Eigen::Vector3d::Zero ();
  for (const Eigen::Isometry3d& pose : poses)
    sum -= pose.linear ().col (1);
  return sum.norm () > 1e-6 ? Eigen::Vector3d (sum.normalized ()) : Eigen::Vector3d::UnitZ ();
}
}  // namespace visualization
}  // namespace cuefusion
