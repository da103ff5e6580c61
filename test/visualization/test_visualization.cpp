// SPDX-License-Identifier: BSD-3-Clause
// Off-screen rendering: analytic scenes, and the rendered labelled mesh against a raycast
// of the same map.
#include "test_utils.h"

#include <cuefusion/common/label_colors.h>
#include <cuefusion/io/map_io.h>
#include <cuefusion/io/mesh_io.h>
#include <cuefusion/simulation/simulated_detector.h>
#include <cuefusion/simulation/synthetic_scene.h>
#include <cuefusion/simulation/synthetic_sequence.h>
#include <cuefusion/pipeline/fusion_pipeline.h>
#include <cuefusion/visualization/frame_view.h>
#include <cuefusion/visualization/mesh_pieces.h>
#include <cuefusion/visualization/mesh_rasterizer.h>

#include <gtest/gtest.h>

#include <cstdlib>
#include <random>
#include <set>
#include <tuple>

using namespace cuefusion;

namespace
{
/** A square of side 2·h at depth z (camera at the origin looking down +z), label \a label. */
void
addSquare (io::TriangleMesh& mesh, float h, float z, std::uint32_t label)
{
  const int base = static_cast<int> (mesh.vertices.size ());
  for (const auto& [x, y] : {std::pair<float, float>{-h, -h}, {h, -h}, {h, h}, {-h, h}})
  {
    mesh.vertices.emplace_back (x, y, z);
    mesh.labels.push_back (label);
    mesh.colors.push_back ({200, 100, 50});
  }
  mesh.triangles.emplace_back (base, base + 1, base + 2);
  mesh.triangles.emplace_back (base, base + 2, base + 3);
}
}  // namespace

TEST (MeshRasterizer, SquaresAtKnownDepthsWithOcclusion)
{
  const PinholeCamera camera (100.0, 100.0, 49.5, 39.5, 100, 80);
  io::TriangleMesh mesh;
  addSquare (mesh, 0.5f, 2.0f, 7);   // projects to ±25 px around the centre
  addSquare (mesh, 0.1f, 1.0f, 3);   // nearer, ±10 px: hides the middle of the first
  const visualization::MeshRasterizer rasterizer;
  const visualization::MeshView view = rasterizer.render (mesh, camera, Eigen::Isometry3d::Identity ());
  ASSERT_EQ (view.labels.size (), cv::Size (100, 80));
  // Centre: the near square.
  EXPECT_EQ (view.labels.at<std::int32_t> (39, 49), 3);
  EXPECT_NEAR (view.depth.at<float> (39, 49), 1.0f, 1e-5f);
  // Inside the far square but outside the near one.
  EXPECT_EQ (view.labels.at<std::int32_t> (39, 49 + 20), 7);
  EXPECT_NEAR (view.depth.at<float> (39, 49 + 20), 2.0f, 1e-5f);
  // Outside both: background.
  EXPECT_EQ (view.labels.at<std::int32_t> (39, 49 + 30), 0);
  EXPECT_EQ (view.depth.at<float> (39, 49 + 30), 0.f);
  EXPECT_EQ (view.image.at<cv::Vec3b> (39, 49 + 30), cv::Vec3b (255, 255, 255));
  // Pixel counts: the far square covers u, v with |u − 49.5|, |v − 39.5| ≤ 25 → 50 × 50.
  int far = 0, near = 0;
  for (int r = 0; r < 80; ++r)
    for (int c = 0; c < 100; ++c)
    {
      far += view.labels.at<std::int32_t> (r, c) == 7;
      near += view.labels.at<std::int32_t> (r, c) == 3;
    }
  EXPECT_EQ (near, 20 * 20);
  EXPECT_EQ (far, 50 * 50 - 20 * 20);
  // Segment colour: the palette colour shaded (head-on, full light).
  const cv::Vec3b rgb = labelColor (7);
  const cv::Vec3b bgr = view.image.at<cv::Vec3b> (39, 49 + 20);
  EXPECT_NEAR (bgr[0], rgb[2], 1);
  EXPECT_NEAR (bgr[2], rgb[0], 1);
  // Both squares wind counter-clockwise around +z, i.e. face away from this camera:
  // back-face culling removes them; turned around, they are kept.
  visualization::MeshRasterizerConfig culling;
  culling.cull_back_faces = true;
  EXPECT_EQ (cv::countNonZero (visualization::MeshRasterizer (culling).render (mesh, camera, Eigen::Isometry3d::Identity ()).labels), 0);
  io::TriangleMesh flipped = mesh;
  for (Eigen::Vector3i& t : flipped.triangles)
    std::swap (t[1], t[2]);
  EXPECT_EQ (cv::countNonZero (visualization::MeshRasterizer (culling).render (flipped, camera, Eigen::Isometry3d::Identity ()).labels), 50 * 50);
  // A camera moved behind the squares sees nothing.
  Eigen::Isometry3d behind = Eigen::Isometry3d::Identity ();
  behind.translation ().z () = 3.0;
  EXPECT_EQ (cv::countNonZero (rasterizer.render (mesh, camera, behind).labels), 0);
}

TEST (MeshRasterizer, OrbitViewsLookAtTheMesh)
{
  io::TriangleMesh mesh;
  addSquare (mesh, 0.5f, 2.0f, 7);
  const PinholeCamera camera (300.0, 300.0, 159.5, 119.5, 320, 240);
  const auto poses = visualization::orbitViews (mesh, camera, 6);
  ASSERT_EQ (poses.size (), 6u);
  const visualization::MeshRasterizer rasterizer;
  for (const auto& pose : poses)
  {
    const Eigen::Vector3d forward = pose.linear ().col (2);
    const Eigen::Vector3d to_centre = (Eigen::Vector3d (0, 0, 2) - pose.translation ()).normalized ();
    EXPECT_GT (forward.dot (to_centre), 0.999);
    EXPECT_GT (cv::countNonZero (rasterizer.render (mesh, camera, pose).labels), 100);
  }
  EXPECT_THROW (visualization::orbitViews (mesh, camera, 0), ParameterError);

  // A stray speck 20 m off (1 % of the vertices) does not set the framing: the map still
  // fills a fair part of every view (with the plain bounding box it was a dot of < 1 %).
  io::TriangleMesh with_speck;
  for (int k = 0; k < 100; ++k)
    addSquare (with_speck, 0.5f, 2.0f, 7);
  with_speck.vertices.emplace_back (20.f, 0.f, 2.f);
  with_speck.vertices.emplace_back (20.01f, 0.f, 2.f);
  with_speck.vertices.emplace_back (20.f, 0.01f, 2.f);
  with_speck.vertices.emplace_back (20.f, 0.f, 2.01f);
  for (int k = 0; k < 4; ++k)
  {
    with_speck.labels.push_back (9);
    with_speck.colors.push_back ({10, 10, 10});
  }
  with_speck.triangles.emplace_back (400, 401, 402);
  for (const auto& pose : visualization::orbitViews (with_speck, camera, 4))
    EXPECT_GT (cv::countNonZero (rasterizer.render (with_speck, camera, pose).labels == 7), camera.width * camera.height / 20);
}

TEST (MeshRasterizer, OrbitViewsFrameTheObjectsNotTheRoom)
{
  // A 10 m floor (label 1) with a 20 cm object on it (label 2). Framed by every labelled
  // surface the object is a speck; framed by the object (a run's segments with a class)
  // it fills a good part of every view. Labels not in the mesh fall back to the whole map.
  io::TriangleMesh mesh;
  addSquare (mesh, 5.f, 0.f, 1);
  addSquare (mesh, 0.1f, 0.2f, 2);
  const PinholeCamera camera (300.0, 300.0, 159.5, 119.5, 320, 240);
  const visualization::MeshRasterizer rasterizer;
  const auto object_pixels = [&] (const Eigen::Isometry3d& pose) { return cv::countNonZero (rasterizer.render (mesh, camera, pose).labels == 2); };
  const auto whole = visualization::orbitViews (mesh, camera, 4);
  const auto objects = visualization::orbitViews (mesh, camera, 4, Eigen::Vector3d::UnitZ (), {2});
  const auto absent = visualization::orbitViews (mesh, camera, 4, Eigen::Vector3d::UnitZ (), {9});
  for (std::size_t k = 0; k < 4; ++k)
  {
    EXPECT_LT (object_pixels (whole[k]), camera.width * camera.height / 100) << k;
    EXPECT_GT (object_pixels (objects[k]), camera.width * camera.height / 10) << k;
    EXPECT_TRUE (absent[k].isApprox (whole[k])) << k;
  }
}

TEST (MeshRasterizer, CameraViewsAreTheRunsOwnPosesEvenlySpaced)
{
  // Eleven poses along x, each turned a little about y: three views are the first, the
  // middle and the last; one view the middle; more views than poses repeat poses in order.
  std::vector<Eigen::Isometry3d, Eigen::aligned_allocator<Eigen::Isometry3d>> poses;
  for (int i = 0; i <= 10; ++i)
    poses.push_back (Eigen::Translation3d (i, 0, 0) * Eigen::AngleAxisd (0.01 * i, Eigen::Vector3d::UnitY ()));
  const auto three = visualization::cameraViews (poses, 3);
  ASSERT_EQ (three.size (), 3u);
  EXPECT_TRUE (three[0].isApprox (poses[0]));
  EXPECT_TRUE (three[1].isApprox (poses[5]));
  EXPECT_TRUE (three[2].isApprox (poses[10]));
  ASSERT_EQ (visualization::cameraViews (poses, 1).size (), 1u);
  EXPECT_TRUE (visualization::cameraViews (poses, 1)[0].isApprox (poses[5]));
  const auto many = visualization::cameraViews (poses, 25);
  ASSERT_EQ (many.size (), 25u);
  for (std::size_t k = 1; k < many.size (); ++k)
    EXPECT_LE (many[k - 1].translation ().x (), many[k].translation ().x ()) << k;
  EXPECT_TRUE (many.back ().isApprox (poses.back ()));
  test::expectError ([&] { visualization::cameraViews (poses, 0); }, "cameraViews views", "at least 1");
  test::expectError ([&] { visualization::cameraViews ({}, 3); }, "cameraViews poses", "at least one");
  // From a pose inside a room (a wall 2 m ahead, one behind the camera), the view sees
  // the wall ahead from wall to wall.
  io::TriangleMesh room;
  addSquare (room, 3.f, 2.f, 4);
  addSquare (room, 3.f, -2.f, 5);
  const visualization::MeshRasterizer rasterizer;
  const PinholeCamera camera (300.0, 300.0, 159.5, 119.5, 320, 240);
  const auto inside = visualization::cameraViews ({Eigen::Isometry3d::Identity ()}, 1);
  EXPECT_EQ (cv::countNonZero (rasterizer.render (room, camera, inside[0]).labels == 4), camera.width * camera.height);
}

TEST (MeshRasterizer, SmallPiecesOfAMeshAreLeftOutWholeAndLargeOnesKept)
{
  // A 20 × 20 grid of quads (800 triangles, one piece through shared vertices), two
  // squares of two triangles each apart from it, and one of them sharing a vertex with
  // the grid: with 100 the lone square goes, the grid and the square joined to it stay.
  io::TriangleMesh mesh;
  const int n = 21;
  for (int r = 0; r < n; ++r)
    for (int c = 0; c < n; ++c)
    {
      mesh.vertices.emplace_back (0.05f * c, 0.05f * r, 2.f);
      mesh.labels.push_back (1);
    }
  for (int r = 0; r + 1 < n; ++r)
    for (int c = 0; c + 1 < n; ++c)
    {
      const int i = r * n + c;
      mesh.triangles.emplace_back (i, i + 1, i + n + 1);
      mesh.triangles.emplace_back (i, i + n + 1, i + n);
    }
  addSquare (mesh, 0.1f, 3.f, 2);  // alone
  addSquare (mesh, 0.1f, 4.f, 3);
  mesh.triangles.emplace_back (0, static_cast<int> (mesh.vertices.size ()) - 1, static_cast<int> (mesh.vertices.size ()) - 2);  // joins the last square to the grid
  const io::TriangleMesh kept = visualization::withoutSmallPieces (mesh, 100);
  EXPECT_EQ (kept.triangles.size (), 800u + 2u + 1u);
  std::set<std::uint32_t> labels;
  for (const Eigen::Vector3i& t : kept.triangles)
    labels.insert (kept.labels[static_cast<std::size_t> (t[0])]);
  EXPECT_EQ (labels, (std::set<std::uint32_t>{1, 3}));
  EXPECT_EQ (kept.vertices.size (), mesh.vertices.size ());
  EXPECT_EQ (visualization::withoutSmallPieces (mesh, 0).triangles.size (), mesh.triangles.size ());
  EXPECT_EQ (visualization::withoutSmallPieces (mesh, 804).triangles.size (), 0u);
}

TEST (MeshRasterizer, ANoisySurfaceIsShadedByItsVertexNormalsNotAsGrain)
{
  // A 60 cm square facing the camera 1 m away, triangulated at 1 cm with every vertex 0–3 mm
  // off the plane (a TSDF mesh of a noisy wall), its vertex normals the plane's (the TSDF's
  // gradient). Shaded by the vertex normals neighbouring pixels differ by under a grey
  // level on average; by the face normals (a mesh without normals) by several.
  io::TriangleMesh mesh;
  std::mt19937 random (7);
  std::uniform_real_distribution<float> jitter (0.f, 0.003f);
  const int n = 61;
  for (int r = 0; r < n; ++r)
    for (int c = 0; c < n; ++c)
    {
      mesh.vertices.emplace_back (-0.3f + 0.01f * static_cast<float> (c), -0.3f + 0.01f * static_cast<float> (r), 1.f + jitter (random));
      mesh.normals.emplace_back (0.f, 0.f, -1.f);
      mesh.labels.push_back (5);
      mesh.colors.push_back ({200, 200, 200});
    }
  for (int r = 0; r + 1 < n; ++r)
    for (int c = 0; c + 1 < n; ++c)
    {
      const int i = r * n + c;
      mesh.triangles.emplace_back (i, i + n, i + 1);
      mesh.triangles.emplace_back (i + 1, i + n, i + n + 1);
    }
  const PinholeCamera camera (150.0, 150.0, 79.5, 59.5, 160, 120);
  const auto grain = [&] (const io::TriangleMesh& m) {
    const visualization::MeshView view = visualization::MeshRasterizer ().render (m, camera, Eigen::Isometry3d::Identity ());
    double sum = 0.0;
    int pairs = 0;
    for (int v = 20; v < 100; ++v)
      for (int u = 40; u < 120; ++u)
        if (view.labels.at<std::int32_t> (v, u) == 5 && view.labels.at<std::int32_t> (v, u + 1) == 5)
        {
          sum += std::abs (static_cast<int> (view.image.at<cv::Vec3b> (v, u)[1]) - static_cast<int> (view.image.at<cv::Vec3b> (v, u + 1)[1]));
          ++pairs;
        }
    EXPECT_GT (pairs, 80 * 80 * 95 / 100);  // the square covers the window
    return sum / std::max (1, pairs);
  };
  EXPECT_LT (grain (mesh), 1.0);
  io::TriangleMesh faces_only = mesh;
  faces_only.normals.clear ();
  EXPECT_GT (grain (faces_only), 3.0);
}

TEST (MeshRasterizer, RenderedMapMatchesARaycastOfTheSameMap)
{
  // A short orbit of the tabletop in masks mode; the labelled mesh goes through the PLY
  // writer and reader, is rendered from the last pose and compared with the volume's
  // own raycast (labels resolved) from that pose.
  simulation::SyntheticSequenceConfig sc;
  sc.frames = 8;
  sc.width = 320;
  sc.height = 240;
  const simulation::SyntheticSequence sequence (simulation::SyntheticScene::load (test::tabletopScenePath ()), sc);
  pipeline::FusionPipelineConfig config;
  config.mode = pipeline::SegmentationMode::Masks;
  config.reconstruction.use_reference_poses = true;
  pipeline::FusionPipeline fusion (config);
  RGBDFrame::Ptr frame;
  for (std::size_t i = 0; i < sequence.size (); ++i)
  {
    frame = sequence.frame (i);
    const std::vector<Instance> instances = simulation::toInstances (sequence.detections (*frame));
    ASSERT_TRUE (fusion.process (*frame, &instances).segmented);
  }
  test::TempDir dir;
  io::saveMeshPLY (dir / "mesh.ply", fusion.labelledMesh ());
  const io::TriangleMesh mesh = io::readMeshPLY (dir / "mesh.ply");
  ASSERT_FALSE (mesh.labels.empty ());
  const visualization::MeshView view =
    visualization::MeshRasterizer ().render (mesh, frame->camera, fusion.reconstruction ().lastGoodPose ());
  const cv::Mat raycast_labels = fusion.modelLabels ();
  const cv::Mat raycast_depth = fusion.reconstruction ().model ().depth ();
  int surface = 0, covered = 0, labelled = 0, agree = 0, depth_close = 0;
  for (int r = 0; r < raycast_labels.rows; ++r)
    for (int c = 0; c < raycast_labels.cols; ++c)
    {
      const float z = raycast_depth.at<float> (r, c);
      if (!isValidDepth (z))
        continue;
      ++surface;
      const float rendered = view.depth.at<float> (r, c);
      if (rendered > 0.f)
      {
        ++covered;
        depth_close += std::abs (rendered - z) < 0.01f;
      }
      const int a = raycast_labels.at<std::int32_t> (r, c), b = view.labels.at<std::int32_t> (r, c);
      if (a > 0 && b > 0)
      {
        ++labelled;
        agree += a == b;
      }
    }
  ASSERT_GT (surface, 30000);
  EXPECT_GT (static_cast<double> (covered) / surface, 0.97);
  EXPECT_GT (static_cast<double> (depth_close) / covered, 0.97);
  ASSERT_GT (labelled, 3000);  // the 8 objects (stuff stays unlabelled in masks mode)
  EXPECT_GT (static_cast<double> (agree) / labelled, 0.95);

  // The Fig. 5.3 panel: colour | depth | labels over colour, each the frame's size.
  const cv::Mat panel = visualization::composeFrameView (*frame, raycast_labels);
  EXPECT_EQ (panel.cols, 3 * frame->color.cols);
  EXPECT_EQ (panel.rows, frame->color.rows);
  int tinted = 0, tinted_right = 0;
  for (int r = 40; r < raycast_labels.rows; ++r)  // below the panel titles
    for (int c = 0; c < raycast_labels.cols; ++c)
    {
      const int label = raycast_labels.at<std::int32_t> (r, c);
      if (label <= 0)
        continue;
      ++tinted;
      const cv::Vec3b rgb = labelColor (static_cast<std::uint32_t> (label));
      const cv::Vec3b in = frame->color.at<cv::Vec3b> (r, c);
      const cv::Vec3b out = panel.at<cv::Vec3b> (r, c + 2 * frame->color.cols);
      tinted_right += std::abs (out[0] - (0.7 * rgb[2] + 0.3 * in[0])) <= 1.0 && std::abs (out[2] - (0.7 * rgb[0] + 0.3 * in[2])) <= 1.0;
    }
  ASSERT_GT (tinted, 1000);
  EXPECT_EQ (tinted_right, tinted);
  EXPECT_THROW (visualization::composeFrameView (*frame, cv::Mat::zeros (3, 3, CV_32S)), Error);
}

TEST (MeshRasterizer, UpComesFromTheCameras)
{
  // Cameras of a y-up world looking horizontally: image up (−y_cam) is world +y.
  std::vector<Eigen::Isometry3d, Eigen::aligned_allocator<Eigen::Isometry3d>> cameras;
  for (int k = 0; k < 4; ++k)
  {
    const double a = 0.5 * k;
    cameras.push_back (lookAt (Eigen::Vector3d (std::cos (a), 0.1 * k, std::sin (a)), Eigen::Vector3d::Zero (),
                                   Eigen::Vector3d::UnitY ()));
  }
  EXPECT_GT (visualization::upFromCameras (cameras).dot (Eigen::Vector3d::UnitY ()), 0.99);
  EXPECT_TRUE (visualization::upFromCameras ({}).isApprox (Eigen::Vector3d::UnitZ ()));
  // Orbit views then sit 30° above the x–z plane.
  io::TriangleMesh mesh;
  addSquare (mesh, 0.5f, 2.0f, 7);
  const PinholeCamera camera (300.0, 300.0, 159.5, 119.5, 320, 240);
  for (const auto& pose : visualization::orbitViews (mesh, camera, 5, Eigen::Vector3d::UnitY ()))
  {
    const Eigen::Vector3d from_centre = (pose.translation () - Eigen::Vector3d (0, 0, 2)).normalized ();
    EXPECT_NEAR (std::asin (from_centre.y ()) * 180.0 / M_PI, 30.0, 1e-6);
    EXPECT_GT ((-pose.linear ().col (1)).dot (Eigen::Vector3d::UnitY ()), 0.8);  // image up is world up
  }
}

TEST (LabelColors, NoTwoOfTheFirstHundredsOfLabelsShareAColour)
{
  // Labels 27, 57 and 207 shared one colour when the 30-colour palette repeated; a room
  // holds hundreds of segments. Every label up to labelColorCount () has its own colour,
  // none black (label 0) or grey (unlabelled points in the viewers), and labels that
  // follow each other differ strongly (sum over channels ≥ 100 of 765).
  const std::uint32_t count = labelColorCount ();
  ASSERT_GE (count, 500u);
  std::set<std::tuple<int, int, int>> seen;
  for (std::uint32_t label = 1; label <= count; ++label)
  {
    const cv::Vec3b c = labelColor (label);
    EXPECT_TRUE (seen.emplace (c[0], c[1], c[2]).second) << "label " << label << " repeats a colour";
    EXPECT_FALSE (c[0] == c[1] && c[1] == c[2] && label > 30) << "label " << label << " is grey";
    if (label > 31)
    {
      const cv::Vec3b p = labelColor (label - 1);
      EXPECT_GE (std::abs (c[0] - p[0]) + std::abs (c[1] - p[1]) + std::abs (c[2] - p[2]), 100) << "labels " << label - 1 << ", " << label;
    }
  }
  EXPECT_EQ (labelColor (0), cv::Vec3b (0, 0, 0));
  EXPECT_EQ (labelColor (count + 5), labelColor (5));  // then the sequence repeats
}
