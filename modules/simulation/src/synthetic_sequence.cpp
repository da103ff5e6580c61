// SPDX-License-Identifier: BSD-3-Clause
#include <cuefusion/common/exceptions.h>
#include <cuefusion/common/parallel.h>
#include <cuefusion/io/file_io.h>
#include <cuefusion/simulation/synthetic_sequence.h>

#include <boost/filesystem.hpp>
#include <nlohmann/json.hpp>
#include <pcl/io/pcd_io.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <map>

namespace fs = boost::filesystem;

namespace cuefusion
{
namespace simulation
{
void
SyntheticSequenceConfig::validate () const
{
  if (frames < 1 || frames > 1000000)
    throw ParameterError ("SyntheticSequenceConfig::frames", "must lie in [1, 1000000]");
  if (!(fps > 0.0 && fps <= 1000.0))
    throw ParameterError ("SyntheticSequenceConfig::fps", "must lie in (0, 1000]");
  if (width < 0 || height < 0 || width > 8192 || height > 8192 || ((width == 0) != (height == 0)))
    throw ParameterError ("SyntheticSequenceConfig::width", "width and height must both be given, each in [1, 8192]");
  if (!(gt_cloud_spacing >= 0.001 && gt_cloud_spacing <= 1.0))
    throw ParameterError ("SyntheticSequenceConfig::gt_cloud_spacing", "must lie in [0.001, 1] metres");
  if (!(noise.stereo_baseline > 0.0 && noise.stereo_subpixel >= 0.0 && noise.speckle >= 0.0 && noise.speckle < 1.0 &&
        noise.dark_dropout >= 0.0 && noise.dark_dropout <= 1.0 && noise.edge_fattening_px >= 0 && noise.edge_fattening_px <= 32))
    throw ParameterError ("DepthNoiseConfig", "stereo baseline > 0, subpixel >= 0, speckle in [0, 1), dark dropout in [0, 1], "
                                              "edge fattening in [0, 32] pixels");
  detector.validate ();
}

SyntheticSequence::SyntheticSequence (const SyntheticScene& scene, const SyntheticSequenceConfig& config)
  : scene_ (scene), config_ (config),
    camera_ (config.width > 0 ? scene.camera.scaled (config.width, config.height) : scene.camera), renderer_ (scene_),
    detector_ (scene_, config.detector, config.seed)
{
  config_.validate ();
}

Eigen::Isometry3d
SyntheticSequence::poseAt (std::size_t i) const
{
  const double s = config_.frames > 1 ? static_cast<double> (i) / static_cast<double> (config_.frames - 1) : 0.0;
  return scene_.cameraPoseAt (s);
}

RenderedView
SyntheticSequence::render (std::size_t i) const
{
  return renderer_.render (camera_, poseAt (i), config_.noise, mixSeed (config_.seed, i));
}

RGBDFrame::Ptr
SyntheticSequence::frame (std::size_t i) const
{
  return frame (i, render (i));
}

RGBDFrame::Ptr
SyntheticSequence::frame (std::size_t i, const RenderedView& view) const
{
  auto f = std::make_shared<RGBDFrame> ();
  f->index = i;
  f->timestamp = 1.0 + static_cast<double> (i) / config_.fps;
  f->name = std::to_string (i);
  f->camera = camera_;
  f->pose = poseAt (i);
  f->depth = view.depth;
  f->color = view.color;
  f->instance_mask = view.instance;
  f->class_mask = view.class_ids;
  return f;
}

DetectionResult
SyntheticSequence::detections (const RGBDFrame& frame) const
{
  return detector_.detect (frame.instance_mask, frame.index);
}

pcl::PointCloud<pcl::PointXYZRGBL>::Ptr
SyntheticSequence::groundTruthCloud () const
{
  auto cloud = pcl::make_shared<pcl::PointCloud<pcl::PointXYZRGBL>> ();
  // Contact faces (a mug's base on the table, the table top under it) lie inside a
  // neighbour grown by this margin and are dropped: no camera can see them.
  const double margin = 1e-3;
  // Every part's bounding sphere grown by twice the margin holds its solid grown by the
  // margin (√3 · margin at a box's corner). Only the parts whose spheres meet the sampled
  // part's can hide its points, and a point outside a sphere is not inside its part: the
  // cheap tests spare the rotation in Primitive::contains for almost every pair (it was
  // most of the time of writing a small sequence).
  struct Bound
  {
    const Primitive* part;
    double radius;
  };
  std::vector<Bound> bounds;
  for (const SceneObject& other : scene_.objects)
    for (const Primitive& part : other.parts)
      bounds.push_back ({&part, part.boundingRadius () + 2 * margin});
  std::vector<Bound> near;
  for (const SceneObject& o : scene_.objects)
    for (std::size_t k = 0; k < o.parts.size (); ++k)
    {
      const Primitive& sampled = o.parts[k];
      near.clear ();
      for (const Bound& b : bounds)
        if (b.part != &sampled && (b.part->center - sampled.center).norm () < b.radius + sampled.boundingRadius () + 2 * margin)
          near.push_back (b);
      std::vector<Eigen::Vector3d> points;
      sampled.sampleSurface (config_.gt_cloud_spacing, points);
      for (const Eigen::Vector3d& p : points)
      {
        bool hidden = false;
        for (std::size_t b = 0; b < near.size () && !hidden; ++b)
          hidden = (p - near[b].part->center).squaredNorm () < near[b].radius * near[b].radius && near[b].part->contains (p, margin);
        if (hidden)
          continue;
        pcl::PointXYZRGBL q;
        q.x = static_cast<float> (p.x ());
        q.y = static_cast<float> (p.y ());
        q.z = static_cast<float> (p.z ());
        q.r = o.rgb[0];
        q.g = o.rgb[1];
        q.b = o.rgb[2];
        q.a = 255;
        q.label = o.id;
        cloud->push_back (q);
      }
    }
  return cloud;
}

void
SyntheticSequence::markObserved (const pcl::PointCloud<pcl::PointXYZRGBL>& cloud, std::size_t i, const RenderedView& view,
                                 std::vector<char>& observed, const CloudCells* cells) const
{
  if (observed.size () != cloud.size ())
    throw Error ("SyntheticSequence::markObserved", "needs one flag per point");
  if (cells && cells->cloud_size != cloud.size ())
    throw Error ("SyntheticSequence::markObserved", "needs the cloud's own cells (cloudCells)");
  const Eigen::Isometry3f to_camera = poseAt (i).inverse ().cast<float> ();
  // The transform written out (Eigen's own order of the sums): called through Eigen it
  // was most of the time of writing a sequence in the instrumented (sanitizer) build.
  const Eigen::Matrix3f r = to_camera.linear ();
  const Eigen::Vector3f t = to_camera.translation ();
  const PinholeCamera& k = camera_;
  // lround (x) is in [0, n) exactly when −0.5 < x < n − 0.5: the comparisons spare the
  // rounding for the points out of view (most of them, every frame).
  const float u_end = static_cast<float> (view.depth.cols) - 0.5f, v_end = static_cast<float> (view.depth.rows) - 0.5f;
  // A cube is out of view when its bounding sphere lies behind the camera or wholly
  // outside one of the four planes through the camera centre and the image's outer pixel
  // edges (where the comparisons below fail); a millimetre's margin keeps rounding safe.
  const float fx = static_cast<float> (k.fx), fy = static_cast<float> (k.fy);
  const float cx = static_cast<float> (k.cx), cy = static_cast<float> (k.cy);
  const Eigen::Vector3f sides[4] = {Eigen::Vector3f (fx, 0.f, cx + 0.5f).normalized (),
                                    Eigen::Vector3f (-fx, 0.f, u_end - cx).normalized (),
                                    Eigen::Vector3f (0.f, fy, cy + 0.5f).normalized (),
                                    Eigen::Vector3f (0.f, -fy, v_end - cy).normalized ()};
  const auto outOfView = [&] (const Eigen::Vector3f& centre) {
    const float radius = 0.5f * std::sqrt (3.f) * CloudCells::kSide + 1e-3f;
    const Eigen::Vector3f c = r * centre + t;
    if (c.z () + radius <= 0.f)
      return true;
    for (const Eigen::Vector3f& side : sides)
      if (side.dot (c) < -radius)
        return true;
    return false;
  };
  const int groups = cells ? static_cast<int> (cells->centre.size ()) : 1;
  parallelForChunks (groups, 1, [&] (int group, int, int) {
    if (cells && outOfView (cells->centre[group]))
      return;
    const std::size_t begin = cells ? cells->begin[group] : 0, end = cells ? cells->begin[group + 1] : cloud.size ();
    for (std::size_t k_point = begin; k_point < end; ++k_point)
    {
      const std::size_t p = cells ? cells->points[k_point] : k_point;
      if (observed[p])
        continue;
      const pcl::PointXYZRGBL& point = cloud[p];
      const Eigen::Vector3f q (r (0, 0) * point.x + r (0, 1) * point.y + r (0, 2) * point.z + t.x (),
                               r (1, 0) * point.x + r (1, 1) * point.y + r (1, 2) * point.z + t.y (),
                               r (2, 0) * point.x + r (2, 1) * point.y + r (2, 2) * point.z + t.z ());
      if (!(q.z () > 0.f))
        continue;
      const float uf = fx * q.x () / q.z () + cx;
      const float vf = fy * q.y () / q.z () + cy;
      if (!(uf > -0.5f && uf < u_end && vf > -0.5f && vf < v_end))
        continue;
      const int u = static_cast<int> (std::lround (uf)), v = static_cast<int> (std::lround (vf));
      if (view.depth.at<float> (v, u) <= 0.f || view.instance.at<std::uint16_t> (v, u) != point.label)
        continue;
      // The seen surface's tangent plane through the pixel's exact point, along the point's ray.
      const float z0 = view.exact_depth.at<float> (v, u);
      const cv::Vec3f n = view.normals.at<cv::Vec3f> (v, u);
      const Eigen::Vector3f normal (n[0], n[1], n[2]);
      const Eigen::Vector3f centre ((static_cast<float> (u) - cx) / fx * z0, (static_cast<float> (v) - cy) / fy * z0, z0);
      const Eigen::Vector3f ray ((uf - cx) / fx, (vf - cy) / fy, 1.f);
      const float along = normal.dot (ray);
      const float z_plane = std::abs (along) > 1e-6f ? normal.dot (centre) / along : z0;
      observed[p] = std::abs (q.z () - z_plane) <= 0.005f;
    }
  });
}

CloudCells
SyntheticSequence::cloudCells (const pcl::PointCloud<pcl::PointXYZRGBL>& cloud)
{
  CloudCells cells;
  cells.cloud_size = cloud.size ();
  const auto cellOf = [&cloud] (std::uint32_t p) {
    const Eigen::Vector3f q = cloud[p].getVector3fMap () / CloudCells::kSide;
    return std::array<long, 3>{std::lround (std::floor (q.x ())), std::lround (std::floor (q.y ())), std::lround (std::floor (q.z ()))};
  };
  std::vector<std::pair<std::array<long, 3>, std::uint32_t>> keyed;
  keyed.reserve (cloud.size ());
  for (std::uint32_t p = 0; p < cloud.size (); ++p)
    keyed.emplace_back (cellOf (p), p);
  std::sort (keyed.begin (), keyed.end ());
  for (std::size_t k = 0; k < keyed.size (); ++k)
  {
    if (k == 0 || keyed[k].first != keyed[k - 1].first)
    {
      cells.begin.push_back (static_cast<std::uint32_t> (k));
      const std::array<long, 3>& c = keyed[k].first;
      cells.centre.push_back ((Eigen::Vector3f (c[0], c[1], c[2]) + Eigen::Vector3f::Constant (0.5f)) * CloudCells::kSide);
    }
    cells.points.push_back (keyed[k].second);
  }
  cells.begin.push_back (static_cast<std::uint32_t> (keyed.size ()));
  return cells;
}

namespace
{
std::string
sceneJson (const SyntheticSequence& sequence, const pcl::PointCloud<pcl::PointXYZRGBL>& cloud)
{
  std::map<std::uint32_t, std::size_t> points;  // by instance, in gt_cloud.pcd
  for (const auto& p : cloud)
    ++points[p.label];
  const SyntheticScene& scene = sequence.scene ();
  nlohmann::json instances = nlohmann::json::array ();
  for (const SceneObject& o : scene.objects)
    instances.push_back ({{"id", o.id},
                          {"name", o.name},
                          {"class_id", scene.classIdOf (o)},
                          {"class_name", o.class_name},
                          {"detectable", o.detectable},
                          {"size", {o.bounds ().sizes ().x (), o.bounds ().sizes ().y (), o.bounds ().sizes ().z ()}},
                          {"gt_points", points.count (o.id) ? points.at (o.id) : 0}});
  const PinholeCamera& c = sequence.camera ();
  nlohmann::json j = {{"scene", scene.name},
                      {"frames", sequence.size ()},
                      {"camera", {{"width", c.width}, {"height", c.height}, {"fx", c.fx}, {"fy", c.fy}, {"cx", c.cx}, {"cy", c.cy}}},
                      {"classes", scene.classNames ()},
                      {"instances", instances}};
  return io::jsonText (j, 1) + "\n";
}
}  // namespace

void
writeSyntheticSequence (const SyntheticSequence& sequence, io::DatasetLayout layout, const std::string& dir,
                        bool overwrite, const std::function<void (std::size_t)>& progress)
{
  io::writeFolderAtomic (dir, overwrite, [&] (const std::string& staging_dir) {
    const fs::path staging (staging_dir);
    std::unique_ptr<io::SequenceWriter> writer = io::SequenceWriter::create (layout, staging.string (), sequence.camera ());
    fs::create_directories (staging / "detections");
    auto cloud = sequence.groundTruthCloud ();
    std::vector<char> observed (cloud->size (), sequence.config ().gt_observed_only ? 0 : 1);
    const CloudCells cells = SyntheticSequence::cloudCells (*cloud);
    for (std::size_t i = 0; i < sequence.size (); ++i)
    {
      const RenderedView view = sequence.render (i);
      const RGBDFrame::Ptr frame = sequence.frame (i, view);
      writer->write (*frame);
      if (sequence.config ().gt_observed_only)
        sequence.markObserved (*cloud, i, view, observed, &cells);
      const DetectionResult detections = sequence.detections (*frame);
      const std::string stem = (staging / "detections" / writer->frameName (*frame)).string ();
      io::writeImageAtomic (stem + ".png", detections.ids);
      io::writeTextAtomic (stem + ".json", detectionsToJson (detections));
      if (progress)
        progress (i + 1);
    }
    writer->finish ();
    std::size_t kept = 0;
    for (std::size_t i = 0; i < cloud->size (); ++i)
      if (observed[i])
        (*cloud)[kept++] = (*cloud)[i];
    cloud->resize (kept);
    cloud->width = static_cast<std::uint32_t> (kept);
    cloud->height = 1;
    io::writeFileAtomic ((staging / "gt_cloud.pcd").string (),
                     [&cloud] (const std::string& tmp) { return pcl::io::savePCDFileBinaryCompressed (tmp, *cloud) == 0; });
    io::writeTextAtomic ((staging / "scene.json").string (), sceneJson (sequence, *cloud));
  });
}
}  // namespace simulation
}  // namespace cuefusion
