// SPDX-License-Identifier: BSD-3-Clause
#include "reconstruction_fixtures.h"

#include <cuefusion/io/map_io.h>
#include <cuefusion/simulation/synthetic_sequence.h>
#include <cuefusion/reconstruction/tsdf_volume.h>

#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>
#include <pcl/conversions.h>
#include <pcl/io/ply_io.h>

#include <algorithm>
#include <cstring>
#include <fstream>

using namespace cuefusion;
using namespace cuefusion::reconstruction;

namespace
{
double
quantile (std::vector<double> v, double q)
{
  std::sort (v.begin (), v.end ());
  return v[static_cast<std::size_t> (q * static_cast<double> (v.size () - 1))];
}

/** Distance to the nearer of the two solids and its outward normal. */
void
analyticSurface (const simulation::SyntheticScene& scene, const Eigen::Vector3d& p, double& distance, Eigen::Vector3d& normal)
{
  const simulation::Primitive& sphere = scene.objects[0].parts[0];
  const simulation::Primitive& box = scene.objects[1].parts[0];
  const double ds = (p - sphere.center).norm () - sphere.half_size.x ();
  const double db = test::boxDistance (box, p);
  if (std::abs (ds) < std::abs (db))
  {
    distance = ds;
    normal = (p - sphere.center).normalized ();
    return;
  }
  distance = db;
  const double h = 1e-4;
  Eigen::Vector3d g;
  for (int k = 0; k < 3; ++k)
    g[k] = test::boxDistance (box, p + h * Eigen::Vector3d::Unit (k)) - test::boxDistance (box, p - h * Eigen::Vector3d::Unit (k));
  normal = g.normalized ();
}
}  // namespace

namespace
{
/** \brief Distance from \a p to the voxel numbered \a v (its block id and index). */
float
nearerVoxelDistance (const TSDFVolume& volume, VoxelNumber v, const Eigen::Vector3f& p)
{
  const std::size_t id = v / kBlockVoxels, local = v % kBlockVoxels;
  if (id >= volume.blockCount ())
    return std::numeric_limits<float>::infinity ();
  const Eigen::Vector3i offset (static_cast<int> (local % kBlockSide), static_cast<int> ((local / kBlockSide) % kBlockSide),
                                static_cast<int> (local / (kBlockSide * kBlockSide)));
  return (volume.voxelPosition (volume.store ().block (id).index * kBlockSide + offset) - p).norm ();
}
}  // namespace

TEST (TSDFVolume, SurfacePointsLieOnTheAnalyticSurface)
{
  const simulation::SyntheticScene scene = test::sphereAndBoxScene ();
  TSDFVolume volume;
  test::integrateOrbit (scene, 16, volume);
  pcl::PointCloud<pcl::PointXYZRGBL> cloud;
  pcl::PointCloud<pcl::Normal> normals;
  // Labelled by the number of the voxel nearer each point (+ 1, 0 being "none").
  volume.extractPointCloud (cloud, &normals, [] (VoxelNumber v) { return v + 1; });
  ASSERT_EQ (cloud.size (), normals.size ());
  ASSERT_GT (cloud.size (), 5000u);
  for (const pcl::PointXYZRGBL& p : cloud)
  {
    ASSERT_GT (p.label, 0u);
    ASSERT_LE (nearerVoxelDistance (volume, p.label - 1, p.getVector3fMap ()), 0.5f * volume.getConfig ().voxel_size + 1e-5f);
  }
  std::vector<double> distance, sphere_distance, angle;
  for (std::size_t i = 0; i < cloud.size (); ++i)
  {
    double d;
    Eigen::Vector3d n;
    analyticSurface (scene, cloud[i].getVector3fMap ().cast<double> (), d, n);
    distance.push_back (std::abs (d));
    if ((cloud[i].getVector3fMap ().cast<double> () - scene.objects[0].parts[0].center).norm () < 0.2)
      sphere_distance.push_back (std::abs (d));
    if (std::isfinite (normals[i].normal_x))
      angle.push_back (std::acos (std::clamp (n.dot (normals[i].getNormalVector3fMap ().cast<double> ()), -1.0, 1.0)) * 180.0 / M_PI);
  }
  const double voxel = volume.getConfig ().voxel_size;
  EXPECT_LT (quantile (sphere_distance, 0.99), 0.5 * voxel);
  // The cube's edges bevel: projective distances near a silhouette edge are too short.
  EXPECT_LT (quantile (distance, 0.5), 0.15 * voxel);
  EXPECT_LT (quantile (distance, 0.9), 0.75 * voxel);
  // Gradient normals of a projective TSDF are noisier than its zero crossings.
  EXPECT_LT (quantile (angle, 0.5), 8.0);
}

TEST (TSDFVolume, RaycastDepthMatchesRenderedDepth)
{
  const simulation::SyntheticScene scene = test::sphereAndBoxScene ();
  TSDFVolume volume;
  test::integrateOrbit (scene, 16, volume);
  const simulation::SceneRenderer renderer (scene);
  // A view between the integrated ones.
  const Eigen::Isometry3d pose = scene.trajectory.poseAt (0.53);
  const simulation::RenderedView truth = renderer.render (scene.camera, pose);
  const RaycastResult model = test::rendered (volume, scene.camera, pose);
  const cv::Mat depth = model.depth ();
  std::vector<double> error;
  std::size_t rendered = 0, missing = 0, spurious = 0;
  for (int v = 0; v < depth.rows; ++v)
    for (int u = 0; u < depth.cols; ++u)
    {
      const float z = truth.depth.at<float> (v, u), m = depth.at<float> (v, u);
      if (z > 0.f)
      {
        ++rendered;
        if (m > 0.f)
          error.push_back (std::abs (z - m));
        else
          ++missing;
      }
      else if (m > 0.f)
        ++spurious;
    }
  ASSERT_GT (rendered, 5000u);
  EXPECT_LT (static_cast<double> (missing), 0.02 * static_cast<double> (rendered));
  // The model extends a little past silhouettes (the TSDF bevels them).
  EXPECT_LT (static_cast<double> (spurious), 0.05 * static_cast<double> (rendered));
  EXPECT_LT (quantile (error, 0.5), 0.002);
  EXPECT_LT (quantile (error, 0.8), 0.005);
  // Normals: unit length, facing the camera, close to the analytic ones.
  std::vector<double> angle;
  for (int v = 0; v < depth.rows; ++v)
    for (int u = 0; u < depth.cols; ++u)
    {
      const cv::Vec3f n = model.normals.at<cv::Vec3f> (v, u), p = model.vertices.at<cv::Vec3f> (v, u);
      const cv::Vec3f t = truth.normals.at<cv::Vec3f> (v, u);
      if (std::isnan (n[0]) || truth.depth.at<float> (v, u) <= 0.f)
        continue;
      ASSERT_NEAR (cv::norm (n), 1.0, 1e-4);
      ASSERT_LT (n.dot (p), 0.f);
      angle.push_back (std::acos (std::clamp (static_cast<double> (n.dot (t)), -1.0, 1.0)) * 180.0 / M_PI);
    }
  // Fusing projective distances from views at different incidence angles tilts the
  // field's gradient by a few degrees (a single view gives ~1°; see the next test).
  EXPECT_LT (quantile (angle, 0.5), 7.0);
  EXPECT_LT (quantile (angle, 0.9), 20.0);
}

TEST (TSDFVolume, RaycastOfAnIntegratedViewReproducesIt)
{
  const simulation::SyntheticScene scene = simulation::SyntheticScene::load (test::tabletopScenePath ());
  const simulation::SceneRenderer renderer (scene);
  const Eigen::Isometry3d pose = scene.trajectory.poseAt (0.0);
  const simulation::RenderedView truth = renderer.render (scene.camera, pose);
  TSDFVolume volume;
  volume.integrate (truth.depth, truth.color, scene.camera, pose);
  const cv::Mat depth = test::rendered (volume, scene.camera, pose).depth ();
  std::size_t valid = 0, matched = 0;
  std::vector<double> error;
  for (int v = 0; v < depth.rows; ++v)
    for (int u = 0; u < depth.cols; ++u)
    {
      const float z = truth.depth.at<float> (v, u);
      if (z > 0.f && z < volume.getConfig ().max_depth)
      {
        ++valid;
        matched += std::abs (depth.at<float> (v, u) - z) < 0.003f;
        error.push_back (depth.at<float> (v, u) > 0.f ? std::abs (depth.at<float> (v, u) - z) : 1.0);
      }
    }
  // Silhouettes and the edges of thin objects bevel by up to a voxel; elsewhere the raycast
  // lands on the rendered surface.
  EXPECT_GT (static_cast<double> (matched), 0.90 * static_cast<double> (valid));
  EXPECT_LT (quantile (error, 0.5), 0.0001);
}

TEST (TSDFVolume, RaycastNormalsOfASingleViewMatchTheSurface)
{
  const simulation::SyntheticScene scene = test::sphereAndBoxScene ();
  const simulation::SceneRenderer renderer (scene);
  const Eigen::Isometry3d pose = scene.trajectory.poseAt (0.3);
  const simulation::RenderedView truth = renderer.render (scene.camera, pose);
  TSDFVolume volume;
  volume.integrate (truth.depth, truth.color, scene.camera, pose);
  const RaycastResult model = test::rendered (volume, scene.camera, pose);
  std::vector<double> angle;
  for (int v = 0; v < truth.depth.rows; ++v)
    for (int u = 0; u < truth.depth.cols; ++u)
    {
      const cv::Vec3f n = model.normals.at<cv::Vec3f> (v, u), t = truth.normals.at<cv::Vec3f> (v, u);
      if (!std::isnan (n[0]) && truth.depth.at<float> (v, u) > 0.f)
        angle.push_back (std::acos (std::clamp (static_cast<double> (n.dot (t)), -1.0, 1.0)) * 180.0 / M_PI);
    }
  ASSERT_GT (angle.size (), 5000u);
  EXPECT_LT (quantile (angle, 0.5), 2.0);
  EXPECT_LT (quantile (angle, 0.9), 6.0);
}

TEST (TSDFVolume, MeshVerticesLieOnTheSurfaceAndFacesPointOutwards)
{
  const simulation::SyntheticScene scene = test::sphereAndBoxScene ();
  TSDFVolume volume;
  test::integrateOrbit (scene, 16, volume);
  const pcl::PolygonMesh mesh = volume.extractMesh ([] (VoxelNumber v) { return v + 1; });
  pcl::PointCloud<pcl::PointXYZRGBL> points;
  pcl::fromPCLPointCloud2 (mesh.cloud, points);
  ASSERT_GT (mesh.polygons.size (), 10000u);
  for (const pcl::PointXYZRGBL& p : points)  // each vertex labelled by its nearer voxel
    ASSERT_LE (nearerVoxelDistance (volume, p.label - 1, p.getVector3fMap ()), 0.5f * volume.getConfig ().voxel_size + 1e-5f);
  EXPECT_TRUE (volume.extractTriangleMesh ().labels.empty ());  // no label function, no labels
  std::vector<std::string> fields;
  for (const auto& f : mesh.cloud.fields)
    fields.push_back (f.name);
  for (const char* name : {"x", "rgba", "label", "normal_x"})
    EXPECT_NE (std::find (fields.begin (), fields.end (), name), fields.end ()) << name;
  const simulation::Primitive& sphere = scene.objects[0].parts[0];
  std::size_t sphere_faces = 0, outward = 0;
  std::vector<double> distance;
  for (const auto& face : mesh.polygons)
  {
    ASSERT_EQ (face.vertices.size (), 3u);
    const Eigen::Vector3d a = points[static_cast<std::size_t> (face.vertices[0])].getVector3fMap ().cast<double> ();
    const Eigen::Vector3d b = points[static_cast<std::size_t> (face.vertices[1])].getVector3fMap ().cast<double> ();
    const Eigen::Vector3d c = points[static_cast<std::size_t> (face.vertices[2])].getVector3fMap ().cast<double> ();
    const Eigen::Vector3d centroid = (a + b + c) / 3.0;
    if ((centroid - sphere.center).norm () > 0.2)
      continue;
    ++sphere_faces;
    distance.push_back (std::abs ((centroid - sphere.center).norm () - sphere.half_size.x ()));
    outward += (b - a).cross (c - a).dot (centroid - sphere.center) > 0.0;
  }
  ASSERT_GT (sphere_faces, 1000u);
  EXPECT_GT (static_cast<double> (outward), 0.99 * static_cast<double> (sphere_faces));
  EXPECT_LT (quantile (distance, 0.99), 0.5 * volume.getConfig ().voxel_size);

  // The PLY writer keeps every vertex, face and the label property.
  test::TempDir dir;
  const std::string path = dir.str () + "/mesh.ply";
  io::saveMeshPLY (path, mesh);
  pcl::PolygonMesh read;
  ASSERT_EQ (pcl::io::loadPLYFile (path, read), 0);
  EXPECT_EQ (read.polygons.size (), mesh.polygons.size ());
  EXPECT_EQ (static_cast<std::size_t> (read.cloud.width) * read.cloud.height, points.size ());
  bool has_label = false;
  for (const auto& f : read.cloud.fields)
    has_label |= f.name == "label";
  EXPECT_TRUE (has_label);
}

namespace
{
// Every block's distance layer holds its own voxels' encoded distances, and its apron the
// distances of the voxels one past its positive faces, read through the hash from the
// blocks that own them ("unobserved" where none is allocated), whatever order the blocks
// were allocated and integrated in.
void
expectDistanceLayersMatchTheVoxels (const TSDFVolume& volume)
{
  std::size_t mirrored = 0;
  for (std::size_t id = 0; id < volume.store ().size (); ++id)
  {
    const VoxelBlock& block = volume.store ().block (id);
    for (int z = 0; z <= kBlockSide; ++z)
      for (int y = 0; y <= kBlockSide; ++y)
        for (int x = 0; x <= kBlockSide; ++x)
        {
          const Eigen::Vector3i voxel = block.index * kBlockSide + Eigen::Vector3i (x, y, z);
          const TsdfVoxel* owner = volume.store ().findVoxel (voxel);
          const std::int16_t expected = owner != nullptr ? encodeDistance (*owner) : kUnobservedDistance;
          ASSERT_EQ (block.distances[static_cast<std::size_t> (distanceIndex (x, y, z))], expected)
              << "block " << id << ", local voxel " << x << " " << y << " " << z;
          mirrored += (x == kBlockSide || y == kBlockSide || z == kBlockSide) && expected != kUnobservedDistance;
        }
  }
  EXPECT_GT (mirrored, volume.store ().size ());  // a surface's blocks have observed neighbours
}
}  // namespace

TEST (TSDFVolume, SaveLoadRoundTripIsExact)
{
  const simulation::SyntheticScene scene = test::sphereAndBoxScene (160, 120);
  TSDFVolumeConfig config;
  config.voxel_size = 0.02;
  config.bounds = Eigen::AlignedBox3d (Eigen::Vector3d (-1, -1, 0), Eigen::Vector3d (1, 1, 2));
  TSDFVolume volume (config);
  test::integrateOrbit (scene, 4, volume);
  test::TempDir dir;
  const std::string path = dir.str () + "/volume.tsdf";
  volume.save (path);
  const TSDFVolume loaded = TSDFVolume::load (path);
  EXPECT_EQ (loaded.getConfig ().voxel_size, config.voxel_size);
  ASSERT_TRUE (loaded.getConfig ().bounds.has_value ());
  EXPECT_TRUE (loaded.getConfig ().bounds->isApprox (*config.bounds));
  ASSERT_EQ (loaded.blockCount (), volume.blockCount ());
  // Both volumes mirror each block's first layers in its neighbours' aprons (what cells
  // across blocks read): load () rebuilds them whatever order the blocks come in.
  {
    SCOPED_TRACE ("integrated");
    expectDistanceLayersMatchTheVoxels (volume);
  }
  {
    SCOPED_TRACE ("loaded");
    expectDistanceLayersMatchTheVoxels (loaded);
  }
  for (std::size_t b = 0; b < volume.store ().size (); ++b)
  {
    const VoxelBlock& block = volume.store ().block (b);
    const std::int32_t id = loaded.store ().findBlock (block.index);
    ASSERT_GE (id, 0);
    EXPECT_EQ (std::memcmp (loaded.store ().block (static_cast<std::size_t> (id)).voxels.data (), block.voxels.data (),
                            sizeof (TsdfVoxel) * kBlockVoxels), 0);
  }

  // Damaged files are refused with the file's name.
  const std::string bytes = test::readFile (path);
  test::writeFile (path + ".cut", bytes.substr (0, bytes.size () - 100));
  test::expectError ([&] { TSDFVolume::load (path + ".cut"); }, path + ".cut", "truncated");
  std::string other = bytes;
  other[8] = 9;  // version
  test::writeFile (path + ".v9", other);
  test::expectError ([&] { TSDFVolume::load (path + ".v9"); }, path + ".v9", "version 9");
  other[8] = 1;  // cuefusion 0.1's, with the labels inside the voxels
  test::writeFile (path + ".v1", other);
  test::expectError ([&] { TSDFVolume::load (path + ".v1"); }, path + ".v1", "version 1");
  test::writeFile (path + ".txt", "not a volume at all, just some text that is long enough to hold a header.........");
  test::expectError ([&] { TSDFVolume::load (path + ".txt"); }, path + ".txt", "not a cuefusion volume");
  test::expectError ([&] { TSDFVolume::load (dir.str () + "/missing.tsdf"); }, "missing.tsdf", "no such file");
}

TEST (TSDFVolume, MemoryFollowsTheSurfaceNotTheViewedVolume)
{
  // A wall 4 m in front of the camera filling the view.
  const std::string text = "scene wall\ncamera 320 240 262.5 262.5 159.5 119.5\n"
                           "object wall class=wall color=200,200,200\n  box center=0,4.05,1 size=8,0.1,8\n";
  const simulation::SyntheticScene scene = simulation::SyntheticScene::parse (text, "wall");
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity ();
  pose.linear () << 1, 0, 0, 0, 0, 1, 0, -1, 0;  // camera z along world +y, looking at the wall
  pose.translation () = Eigen::Vector3d (0, 0, 1);
  const simulation::RenderedView view = simulation::SceneRenderer (scene).render (scene.camera, pose);
  TSDFVolume volume;
  volume.integrate (view.depth, view.color, scene.camera, pose);
  const double block = volume.getConfig ().blockSize ();
  // The view's footprint on the wall is 4.9 m × 3.7 m; its band (2τ = 8 cm) fits in one or
  // two block layers. Filling the frustum in front of the wall would take ~17 times more.
  const double footprint = (4.0 * 320 / 262.5) * (4.0 * 240 / 262.5);
  const double band_blocks = footprint / (block * block);
  const double frustum_blocks = footprint * 4.0 / 3.0 / (block * block * block);
  EXPECT_GT (static_cast<double> (volume.blockCount ()), 0.9 * band_blocks);
  EXPECT_LT (static_cast<double> (volume.blockCount ()), 2.5 * band_blocks);
  EXPECT_LT (static_cast<double> (volume.blockCount ()), 0.15 * frustum_blocks);
  for (const Eigen::Vector3i& index : volume.store ().blockIndices ())
  {
    const double y_near = index.y () * block, y_far = y_near + block;
    EXPECT_GT (y_far, 4.0 - volume.getConfig ().truncation () - 1e-9);
    EXPECT_LT (y_near, 4.0 + volume.getConfig ().truncation () + 1e-9);
  }
  EXPECT_GE (volume.memoryUsage (), volume.blockCount () * sizeof (VoxelBlock));
  volume.reset ();
  EXPECT_EQ (volume.blockCount (), 0u);
}

TEST (VoxelBlockStore, AllocatesOnceFindsVoxelsAndKeepsTheApronsOfWrittenBlocks)
{
  VoxelBlockStore store;
  EXPECT_EQ (store.allocate (Eigen::Vector3i (0, 0, 0)), std::make_pair (0, true));
  EXPECT_EQ (store.allocate (Eigen::Vector3i (0, 0, 0)), std::make_pair (0, false));  // already there
  EXPECT_EQ (store.allocate (Eigen::Vector3i (1, 0, 0)), std::make_pair (1, true));
  ASSERT_EQ (store.size (), 2u);
  EXPECT_EQ (store.blockIndices ()[1], Eigen::Vector3i (1, 0, 0));
  EXPECT_EQ (store.findBlock (Eigen::Vector3i (1, 0, 0)), 1);
  EXPECT_EQ (store.find (packBlockIndex (Eigen::Vector3i (1, 0, 0))), 1);
  EXPECT_EQ (store.findBlock (Eigen::Vector3i (2, 0, 0)), VoxelBlockHash::kNone);

  // Global voxel (9, 3, 5) is local (1, 3, 5) of block 1.
  const std::size_t local = static_cast<std::size_t> (localVoxelIndex (1, 3, 5));
  EXPECT_EQ (store.findVoxelNumber (Eigen::Vector3i (9, 3, 5)), voxelNumber (1, local));
  EXPECT_EQ (store.findVoxel (Eigen::Vector3i (9, 3, 5)), &store.block (1).voxels[local]);
  EXPECT_EQ (store.findVoxelNumber (Eigen::Vector3i (16, 3, 5)), kNoVoxel);
  EXPECT_EQ (store.findVoxel (Eigen::Vector3i (-1, 3, 5)), nullptr);

  // A voxel on block 1's lower x face, written and refreshed: block 1's own distance copy
  // and block 0's apron (its x = 8 layer) both show it.
  TsdfVoxel& voxel = store.block (1).voxels[static_cast<std::size_t> (localVoxelIndex (0, 3, 5))];
  voxel.sdf = -0.25f;
  voxel.weight = 3.f;
  EXPECT_EQ (store.block (0).distances[static_cast<std::size_t> (distanceIndex (8, 3, 5))], kUnobservedDistance);
  store.refreshDistances (1);
  const std::int16_t encoded = encodeDistance (voxel);
  EXPECT_NE (encoded, kUnobservedDistance);
  EXPECT_EQ (store.block (1).distances[static_cast<std::size_t> (distanceIndex (0, 3, 5))], encoded);
  EXPECT_EQ (store.block (0).distances[static_cast<std::size_t> (distanceIndex (8, 3, 5))], encoded);

  // A block allocated later below block 1 (y − 1) takes its y = 8 apron layer from it.
  EXPECT_EQ (store.allocate (Eigen::Vector3i (1, -1, 0)), std::make_pair (2, true));
  store.block (1).voxels[static_cast<std::size_t> (localVoxelIndex (2, 0, 4))] = voxel;
  store.refreshDistances (1);
  EXPECT_EQ (store.block (2).distances[static_cast<std::size_t> (distanceIndex (2, 8, 4))], encoded);
  EXPECT_EQ (store.block (2).distances[static_cast<std::size_t> (distanceIndex (2, 7, 4))], kUnobservedDistance);

  EXPECT_GE (store.memoryUsage (), 3 * sizeof (VoxelBlock));
  store.clear ();
  EXPECT_EQ (store.size (), 0u);
  EXPECT_EQ (store.findBlock (Eigen::Vector3i (0, 0, 0)), VoxelBlockHash::kNone);
}

TEST (TSDFVolume, BoundsLimitAllocation)
{
  const simulation::SyntheticScene scene = test::sphereAndBoxScene (160, 120);
  TSDFVolumeConfig config;
  config.bounds = Eigen::AlignedBox3d (Eigen::Vector3d (-1, -1, 0), Eigen::Vector3d (0, 1, 2));  // the sphere's half
  TSDFVolume volume (config);
  test::integrateOrbit (scene, 4, volume);
  ASSERT_GT (volume.blockCount (), 0u);
  for (const Eigen::Vector3i& index : volume.store ().blockIndices ())
    EXPECT_LE (index.x () * config.blockSize (), 0.0 + 1e-9);
}

TEST (TSDFVolume, RejectsBadInput)
{
  TSDFVolumeConfig config;
  config.voxel_size = -1;
  test::expectError ([&] { TSDFVolume v (config); }, "voxel_size", "must lie");
  TSDFVolume volume;
  const PinholeCamera camera (100, 100, 49.5, 39.5, 100, 80);
  test::expectError ([&] { volume.integrate (cv::Mat (80, 100, CV_16U), cv::Mat (), camera, Eigen::Isometry3d::Identity ()); },
                     "integrate", "CV_32F");
  test::expectError ([&] { volume.integrate (cv::Mat (60, 100, CV_32F, cv::Scalar (1)), cv::Mat (), camera, Eigen::Isometry3d::Identity ()); },
                     "integrate", "size");
}

TEST (TSDFVolume, TheAddressableRangeIsOneLimitForAllocationExtractionAndCameras)
{
  // A wall 1 m in front of a camera near the edge of the addressable range (±2^19 voxels
  // on every axis: ±5,242.88 m at 1 cm) is fused and extracted where it is; a camera
  // beyond the range is refused instead of wrapping the surface extraction's keys.
  const PinholeCamera camera (60, 60, 31.5, 23.5, 64, 48);
  const cv::Mat depth (48, 64, CV_32F, cv::Scalar (1.f));
  TSDFVolumeConfig config;
  const double limit = kVoxelCoordinateLimit * config.voxel_size;
  ASSERT_NEAR (limit, 5242.88, 1e-9);
  for (const Eigen::Vector3d& at : {Eigen::Vector3d (limit - 6.0, -(limit - 6.0), limit - 7.5), Eigen::Vector3d (-(limit - 6.0), limit - 6.0, -(limit - 6.0))})
  {
    TSDFVolume volume (config);
    Eigen::Isometry3d pose = Eigen::Isometry3d::Identity ();
    pose.translation () = at;
    EXPECT_TRUE (volume.reaches (pose));
    volume.integrate (depth, cv::Mat (), camera, pose);
    for (const Eigen::Vector3i& index : volume.store ().blockIndices ())
      ASSERT_TRUE (inBlockRange (index));
    pcl::PointCloud<pcl::PointXYZRGBL> cloud;
    volume.extractPointCloud (cloud);
    ASSERT_GT (cloud.size (), 100u);
    for (const auto& p : cloud)
    {
      ASSERT_NEAR (p.z, at.z () + 1.0, 0.02);
      ASSERT_LE (std::abs (p.x - at.x ()), 0.6);
      ASSERT_LE (std::abs (p.y - at.y ()), 0.45);
    }
  }
  for (const double x : {limit, 6000.0, 1e5, 1e300})
  {
    TSDFVolume volume (config);
    Eigen::Isometry3d pose = Eigen::Isometry3d::Identity ();
    pose.translation ().x () = x;
    EXPECT_FALSE (volume.reaches (pose));
    test::expectError ([&] { volume.integrate (depth, cv::Mat (), camera, pose); }, "integrate", "addressable range");
    EXPECT_EQ (volume.blockCount (), 0u);
  }
}

TEST (TSDFVolume, DepthHintedRaycastMatchesTheFullRaycast)
{
  // Noisy frames: the hint (the measured depth) scatters around the fused surface, so
  // some rays start behind it and must fall back to the full march.
  simulation::SyntheticSequenceConfig config;
  config.frames = 20;
  config.width = 320;
  config.height = 240;
  config.noise.enabled = true;
  const simulation::SyntheticSequence sequence (simulation::SyntheticScene::load (test::tabletopScenePath ()), config);
  TSDFVolume volume;
  for (std::size_t i = 0; i < 10; ++i)
  {
    const RGBDFrame::Ptr frame = sequence.frame (i);
    volume.integrate (frame->depth, frame->color, frame->camera, *frame->pose);
  }
  const RGBDFrame::Ptr last = sequence.frame (9);
  RaycastResult full, hinted;
  volume.raycast (last->camera, *last->pose, full);
  volume.raycast (last->camera, *last->pose, hinted, test::withHint (last->depth));
  const cv::Mat a = full.depth (), b = hinted.depth ();
  std::size_t both = 0, same = 0, only_full = 0;
  for (int v = 0; v < a.rows; ++v)
    for (int u = 0; u < a.cols; ++u)
    {
      const float za = a.at<float> (v, u), zb = b.at<float> (v, u);
      if (za > 0.f && zb > 0.f)
      {
        ++both;
        same += std::abs (za - zb) < 1e-3f;
      }
      else if (za > 0.f)
        ++only_full;
    }
  ASSERT_GT (both, 30000u);
  // Where they differ, the full march found model surface more than two voxels in front
  // of the measured depth (bevelled silhouettes, stale noise): the hint skips it by design.
  EXPECT_GT (static_cast<double> (same), 0.97 * static_cast<double> (both));
  EXPECT_LT (static_cast<double> (only_full), 0.01 * static_cast<double> (both));
}

TEST (TSDFVolume, HintBehindTheSurfaceStillFindsIt)
{
  // A wall 1.2 m in front of the camera, and a hint 5 voxels behind it: Newton from the
  // hint reads unobserved voxels, the march from two voxels in front of the hint starts
  // behind the surface, and the second march from a band further in front must find the
  // wall where the full march does, with its normal.
  const std::string text = "scene wall\ncamera 320 240 262.5 262.5 159.5 119.5\n"
                           "object wall class=wall color=200,200,200\n  box center=0,1.25,1 size=8,0.1,8\n";
  const simulation::SyntheticScene scene = simulation::SyntheticScene::parse (text, "wall");
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity ();
  pose.linear () << 1, 0, 0, 0, 0, 1, 0, -1, 0;  // camera z along world +y
  pose.translation () = Eigen::Vector3d (0, 0, 1);
  const simulation::RenderedView view = simulation::SceneRenderer (scene).render (scene.camera, pose);
  TSDFVolume volume;
  volume.integrate (view.depth, view.color, scene.camera, pose);
  RaycastResult full, hinted;
  volume.raycast (scene.camera, pose, full);
  cv::Mat hint = view.depth + 5.0 * volume.getConfig ().voxel_size;
  volume.raycast (scene.camera, pose, hinted, test::withHint (hint));
  const cv::Mat a = full.depth (), b = hinted.depth ();
  // Away from the view's rim, whose cells have unobserved corners (both marches then
  // use nearest-voxel values and give no normal).
  std::size_t surface = 0, same = 0;
  for (int v = 4; v < a.rows - 4; ++v)
    for (int u = 4; u < a.cols - 4; ++u)
      if (a.at<float> (v, u) > 0.f)
      {
        ++surface;
        same += std::abs (a.at<float> (v, u) - b.at<float> (v, u)) < 1e-3f && hinted.normals.at<cv::Vec3f> (v, u)[2] < -0.99f;
      }
  ASSERT_GT (surface, 70000u);
  EXPECT_GT (static_cast<double> (same), 0.99 * static_cast<double> (surface));
}

TEST (TSDFVolume, HoleSkipSearchesOnlyTheRefreshedHoles)
{
  // A fused tabletop, then a hint with a band of hole pixels punched across it (where the
  // model has surface) and the sky of the view (where it has none).
  simulation::SyntheticSequenceConfig config;
  config.frames = 10;
  config.width = 320;
  config.height = 240;
  const simulation::SyntheticSequence sequence (simulation::SyntheticScene::load (test::tabletopScenePath ()), config);
  TSDFVolume volume;
  for (std::size_t i = 0; i < config.frames; ++i)
  {
    const RGBDFrame::Ptr frame = sequence.frame (i);
    volume.integrate (frame->depth, frame->color, frame->camera, *frame->pose);
  }
  const RGBDFrame::Ptr last = sequence.frame (config.frames - 1);
  cv::Mat hint = last->depth.clone ();
  hint.rowRange (100, 140).setTo (0.f);
  RaycastResult searched, skipped, stale;
  volume.raycast (last->camera, *last->pose, searched, test::withHint (hint));
  ASSERT_EQ (searched.empty_holes.type (), CV_8U);
  const cv::Mat depth = searched.depth ();
  int holes_found = 0, holes_empty = 0;
  for (int v = 0; v < hint.rows; ++v)
    for (int u = 0; u < hint.cols; ++u)
    {
      const bool hole = !(hint.at<float> (v, u) > 0.f), found = depth.at<float> (v, u) > 0.f;
      // Marked only where a hole's search came back empty (rays through tiles without
      // any block are not searched, and not marked).
      if (searched.empty_holes.at<std::uint8_t> (v, u) != 0)
      {
        ASSERT_TRUE (hole && !found) << u << ", " << v;
      }
      holes_found += hole && found;
      holes_empty += searched.empty_holes.at<std::uint8_t> (v, u) != 0;
    }
  ASSERT_GT (holes_found, 5000);  // the band's rays reach the table behind the holes

  // The mask of this very raycast changes nothing: what it skips found nothing anyway.
  RaycastHoleSkip skip;
  skip.empty_holes = searched.empty_holes.clone ();
  skip.phase = 3;
  volume.raycast (last->camera, *last->pose, skipped, test::withHint (hint, skip));
  EXPECT_EQ (cv::countNonZero (skipped.depth () != depth), 0);
  EXPECT_EQ (cv::countNonZero (skipped.empty_holes != searched.empty_holes), 0);

  // A stale mask marking every pixel: hole rays Newton cannot settle are searched only on
  // the refreshed diagonals (u + v + phase) mod 8 = 0; rays with a usable hint as before.
  skip.empty_holes.setTo (255);
  volume.raycast (last->camera, *last->pose, stale, test::withHint (hint, skip));
  const cv::Mat stale_depth = stale.depth ();
  int stale_found = 0, refreshed_found = 0, lost = 0;
  for (int v = 0; v < hint.rows; ++v)
    for (int u = 0; u < hint.cols; ++u)
    {
      const bool hole = !(hint.at<float> (v, u) > 0.f);
      const float z = stale_depth.at<float> (v, u);
      if (!hole)
      {
        ASSERT_EQ (z, depth.at<float> (v, u)) << u << ", " << v;
        continue;
      }
      if (z > 0.f)
      {
        ++stale_found;
        refreshed_found += (static_cast<unsigned> (u + v) + skip.phase) % skip.refresh_period == 0;
      }
      else
      {
        ASSERT_NE (stale.empty_holes.at<std::uint8_t> (v, u), 0) << "an empty hole stays marked: " << u << ", " << v;
        lost += depth.at<float> (v, u) > 0.f;
      }
    }
  // Skipped searches lose surface the full search found; the refreshed diagonals (an
  // eighth) are searched, and Newton from each row's last surface fills most of the band.
  EXPECT_GT (lost, 50) << stale_found << " " << refreshed_found << " " << holes_found;
  EXPECT_GT (refreshed_found, holes_found / 16);
  // In the band's rows (holes from the left edge on) no surface precedes the first one
  // found, so Newton from the row's last surface cannot have found it: a search did, on
  // a refreshed diagonal.
  for (int v = 100; v < 140; ++v)
  {
    const float* row = stale_depth.ptr<float> (v);
    const int first = static_cast<int> (std::find_if (row, row + hint.cols, [] (float z) { return z > 0.f; }) - row);
    if (first < hint.cols)
    {
      EXPECT_EQ ((static_cast<unsigned> (first + v) + skip.phase) % skip.refresh_period, 0u) << "row " << v;
    }
  }

  // Bad masks are refused with a message, not read out of bounds.
  skip.empty_holes = cv::Mat (10, 10, CV_8U, cv::Scalar (0));
  EXPECT_THROW (volume.raycast (last->camera, *last->pose, stale, test::withHint (hint, skip)), Error);
}
