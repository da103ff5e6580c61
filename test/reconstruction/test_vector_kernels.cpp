// SPDX-License-Identifier: BSD-3-Clause
// The AVX2 kernels (integration, ICP and its pixel reads, the pyramid, the raycast) against their scalar versions on
// generated views: both paths must build the same volume and find the same motion.
#include "reconstruction_fixtures.h"

#include <cuefusion/common/avx2.h>
#include <cuefusion/common/cpu_features.h>
#include <cuefusion/reconstruction/preprocessing.h>
#include <cuefusion/reconstruction/projective_icp.h>
#include <cuefusion/reconstruction/vertex_maps.h>

#include <gtest/gtest.h>
#include <opencv2/imgproc.hpp>

#include <cmath>
#include <cstring>
#include <memory>
#include <random>

using namespace cuefusion;
using namespace cuefusion::reconstruction;

namespace
{
/** Sets the kernel choice for one scope and restores it. */
class KernelChoice
{
public:
  explicit KernelChoice (bool vector) : before_ (vectorKernelsEnabled ()) { setVectorKernelsEnabled (vector); }
  ~KernelChoice () { setVectorKernelsEnabled (before_); }

private:
  bool before_;
};

/** Views of the sphere-and-box orbit with holes punched in: NaN, zero and too-far pixels,
  * so the kernels' invalid-depth paths (nearest and bilinear) are exercised too.
  */
std::vector<simulation::RenderedView>
viewsWithHoles (const simulation::SyntheticScene& scene, int count, double sweep = 1.0)
{
  const simulation::SceneRenderer renderer (scene);
  std::mt19937 rng (11);
  std::uniform_int_distribution<int> col (0, scene.camera.width - 1), row (0, scene.camera.height - 1), kind (0, 2);
  std::vector<simulation::RenderedView> views;
  for (int i = 0; i < count; ++i)
  {
    simulation::RenderedView view =
        renderer.render (scene.camera, scene.trajectory.poseAt (sweep * static_cast<double> (i) / count));
    for (int k = 0; k < scene.camera.width * scene.camera.height / 50; ++k)
    {
      const float values[3] = {std::numeric_limits<float>::quiet_NaN (), 0.f, 50.f};
      view.depth.at<float> (row (rng), col (rng)) = values[kind (rng)];
    }
    views.push_back (view);
  }
  return views;
}

TSDFVolume
integrateWith (bool vector, const simulation::SyntheticScene& scene, const std::vector<simulation::RenderedView>& views)
{
  const KernelChoice choice (vector);
  TSDFVolumeConfig config;
  config.voxel_size = 0.01;
  TSDFVolume volume (config);
  for (std::size_t i = 0; i < views.size (); ++i)
    volume.integrate (views[i].depth, views[i].color, scene.camera,
                      scene.trajectory.poseAt (static_cast<double> (i) / static_cast<double> (views.size ())));
  return volume;
}
}  // namespace

TEST (VectorKernels, IntegrationBuildsTheScalarVolume)
{
  if (!cpuHasAvx2Fma ())
    GTEST_SKIP () << "this CPU has no AVX2/FMA: only the scalar kernels run";
  const simulation::SyntheticScene scene = test::sphereAndBoxScene (320, 240);
  const std::vector<simulation::RenderedView> views = viewsWithHoles (scene, 6);
  const TSDFVolume scalar = integrateWith (false, scene, views);
  const TSDFVolume vector = integrateWith (true, scene, views);
  ASSERT_EQ (scalar.blockCount (), vector.blockCount ());  // allocation does not depend on the kernel
  std::size_t observed = 0, weight_differs = 0, sdf_differs = 0, color_differs = 0, distance_differs = 0;
  float max_sdf_difference = 0.f;
  for (std::size_t n = 0; n < scalar.store ().size (); ++n)
  {
    const VoxelBlock& block = scalar.store ().block (n);
    const std::int32_t id = vector.store ().findBlock (block.index);
    ASSERT_GE (id, 0);
    const VoxelBlock& other = vector.store ().block (static_cast<std::size_t> (id));
    for (int i = 0; i < kBlockVoxels; ++i)
    {
      const TsdfVoxel& a = block.voxels[static_cast<std::size_t> (i)];
      const TsdfVoxel& b = other.voxels[static_cast<std::size_t> (i)];
      observed += a.weight > 0.f;
      weight_differs += a.weight != b.weight;
      const float d = std::abs (a.sdf - b.sdf);
      max_sdf_difference = std::max (max_sdf_difference, d);
      sdf_differs += d > 1e-4f;
      color_differs += std::abs (a.r - b.r) > 1 || std::abs (a.g - b.g) > 1 || std::abs (a.b - b.b) > 1;
      // The compact copy must follow each path's own voxels exactly.
      distance_differs +=
          other.distances[static_cast<std::size_t> (distanceIndex (i % kBlockSide, (i / kBlockSide) % kBlockSide, i / (kBlockSide * kBlockSide)))] !=
          encodeDistance (b);
    }
  }
  ASSERT_GT (observed, 50000u);
  // A voxel whose projection falls within rounding of a pixel border may take the other
  // pixel's depth (the positions are computed in a different order): a handful, not more.
  EXPECT_LT (static_cast<double> (weight_differs), 1e-3 * static_cast<double> (observed));
  EXPECT_LT (static_cast<double> (sdf_differs), 1e-3 * static_cast<double> (observed));
  EXPECT_LT (static_cast<double> (color_differs), 1e-3 * static_cast<double> (observed));
  EXPECT_EQ (distance_differs, 0u);
  EXPECT_LT (max_sdf_difference, 0.5f);
}

// A voxel whose nearest pixel lies in the image but whose 2×2 pixel quad does not (the
// half-pixel border) takes its depth from the nearest pixel alone: the vector kernel reads
// those pixels separately from the quads, and must update the same voxels there.
TEST (VectorKernels, IntegrationUsesTheImageBorder)
{
  if (!cpuHasAvx2Fma ())
    GTEST_SKIP () << "this CPU has no AVX2/FMA: only the scalar kernels run";
  const PinholeCamera camera (60.0, 60.0, 31.5, 23.5, 64, 48);
  const cv::Mat depth (camera.height, camera.width, CV_32F, cv::Scalar (1.0f));  // a wall 1 m ahead
  TSDFVolumeConfig config;
  config.voxel_size = 0.01;
  TSDFVolume scalar (config), vector (config);
  {
    const KernelChoice choice (false);
    scalar.integrate (depth, cv::Mat (), camera, Eigen::Isometry3d::Identity ());
  }
  {
    const KernelChoice choice (true);
    vector.integrate (depth, cv::Mat (), camera, Eigen::Isometry3d::Identity ());
  }
  std::size_t border = 0, differs = 0;
  for (std::size_t n = 0; n < scalar.store ().size (); ++n)
    for (int i = 0; i < kBlockVoxels; ++i)
    {
      const VoxelBlock& block = scalar.store ().block (n);
      const Eigen::Vector3i g = block.index * kBlockSide + Eigen::Vector3i (i % kBlockSide, (i / kBlockSide) % kBlockSide, i / (kBlockSide * kBlockSide));
      const TsdfVoxel* other = vector.store ().findVoxel (g);
      ASSERT_NE (other, nullptr);
      const float weight = block.voxels[static_cast<std::size_t> (i)].weight;
      differs += weight != other->weight;
      const Eigen::Vector3f p = scalar.voxelPosition (g);
      if (!(weight > 0.f) || !(p.z () > 0.f))
        continue;
      const Eigen::Vector2f uv = camera.project (p);
      border += uv.x () < 0.f || uv.y () < 0.f || uv.x () >= camera.width - 1.f || uv.y () >= camera.height - 1.f;
    }
  ASSERT_GT (border, 100u);
  // Rounding at the image's outer edge may differ for a voxel or two, not for the border.
  EXPECT_LE (differs, 2u + border / 50);
}

TEST (VectorKernels, ICPFindsTheScalarMotion)
{
  if (!cpuHasAvx2Fma ())
    GTEST_SKIP () << "this CPU has no AVX2/FMA: only the scalar kernels run";
  // 316 px wide: levels of 316, 158 and 79 px leave 4, 6 and 7 pixels per row to the
  // scalar tail; the punched holes put NaN into both pyramids.
  const simulation::SyntheticScene scene = test::sphereAndBoxScene (316, 240);
  const std::vector<simulation::RenderedView> views = viewsWithHoles (scene, 3, 0.0075);  // steps of 1°
  const DepthPreprocessor preprocessor;
  for (const int step : {1, 2})
  {
    FramePyramid source, target;
    preprocessor.compute (views[static_cast<std::size_t> (step)].depth, scene.camera, source);
    preprocessor.compute (views[0].depth, scene.camera, target);
    ICPResult result[2];
    for (const bool vector : {false, true})
    {
      const KernelChoice choice (vector);
      result[vector] = ProjectiveICP ().align (source, target, Eigen::Isometry3d::Identity ());
      ASSERT_TRUE (result[vector].solved);
    }
    const Eigen::Isometry3d truth = scene.trajectory.poseAt (0.0).inverse () * scene.trajectory.poseAt (0.0025 * step);
    for (const ICPResult& r : result)
      EXPECT_LT ((r.transform.translation () - truth.translation ()).norm (), 0.002);
    const Eigen::Isometry3d between = result[0].transform.inverse () * result[1].transform;
    EXPECT_LT (between.translation ().norm (), 1e-4);
    EXPECT_LT (Eigen::AngleAxisd (between.rotation ()).angle (), 1e-4);
    EXPECT_EQ (result[0].source_points, result[1].source_points);
    EXPECT_NEAR (static_cast<double> (result[0].inliers), static_cast<double> (result[1].inliers),
                 1e-3 * static_cast<double> (result[0].inliers));
    EXPECT_NEAR (result[0].rmse, result[1].rmse, 1e-3 * result[0].rmse + 1e-7);
  }
}

#ifdef CUEFUSION_HAVE_AVX2_KERNELS
/** avx2::gatherXyz8 with its results stored as got[coordinate][lane]. */
static CUEFUSION_AVX2 void
gatherXyz8Stored (const float* base, const std::int32_t* offsets, float (&got)[3][8])
{
  __m256 x, y, z;
  avx2::gatherXyz8 (base, offsets, x, y, z);
  _mm256_storeu_ps (got[0], x);
  _mm256_storeu_ps (got[1], y);
  _mm256_storeu_ps (got[2], z);
}

/** avx2::gatherQuads8 with its results stored as got[corner][lane]. */
static CUEFUSION_AVX2 void
gatherQuads8Stored (const float* base, const std::int32_t* offsets, std::ptrdiff_t row_step, float (&got)[4][8])
{
  __m256 c[4];
  avx2::gatherQuads8 (base, offsets, row_step, c[0], c[1], c[2], c[3]);
  for (int k = 0; k < 4; ++k)
    _mm256_storeu_ps (got[k], c[k]);
}

TEST (VectorKernels, PixelGathersReadTheNamedPixels)
{
  if (!cpuHasAvx2Fma ())
    GTEST_SKIP () << "this CPU has no AVX2/FMA: only the scalar kernels run";
  // A CV_32FC3 image's floats, exactly sized: the last pixel's x, y, z end the buffer, so
  // a read of a fourth float there would run past it (as a 16-byte load would).
  const int pixels = 1000;
  const std::unique_ptr<float[]> image (new float[3 * pixels]);
  for (int i = 0; i < 3 * pixels; ++i)
    image[static_cast<std::size_t> (i)] = static_cast<float> (i) * 0.5f - 7.f;
  std::mt19937 rng (3);
  std::uniform_int_distribution<int> pixel (0, pixels - 1);
  for (int round = 0; round < 50; ++round)
  {
    alignas (32) std::int32_t offsets[8];
    for (int i = 0; i < 8; ++i)
      offsets[i] = 3 * (i == round % 8 ? pixels - 1 : pixel (rng));
    float got[3][8];
    gatherXyz8Stored (image.get (), offsets, got);
    for (int i = 0; i < 8; ++i)
      for (int c = 0; c < 3; ++c)
        ASSERT_EQ (got[c][i], image[static_cast<std::size_t> (offsets[i] + c)]) << "lane " << i << ", coordinate " << c;
  }

  // Quads (bilinear depth) of a 37 × 29 image, exactly sized, the last quad included.
  const int width = 37, height = 29;
  const std::unique_ptr<float[]> depth (new float[width * height]);
  for (int i = 0; i < width * height; ++i)
    depth[static_cast<std::size_t> (i)] = static_cast<float> (i) + 0.25f;
  std::uniform_int_distribution<int> column (0, width - 2), row (0, height - 2);
  for (int round = 0; round < 50; ++round)
  {
    alignas (32) std::int32_t offsets[8];
    for (int i = 0; i < 8; ++i)
      offsets[i] = i == round % 8 ? (height - 2) * width + width - 2 : row (rng) * width + column (rng);
    float got[4][8];
    gatherQuads8Stored (depth.get (), offsets, width, got);
    for (int i = 0; i < 8; ++i)
      for (int k = 0; k < 4; ++k)
        ASSERT_EQ (got[k][i], depth[static_cast<std::size_t> (offsets[i] + (k & 1) + (k >> 1) * width)])
            << "lane " << i << ", corner " << k;
  }
}

/** avx2::kinectNoiseAtNormalIncidence of eight depths. */
static CUEFUSION_AVX2 void
noiseLanes (const float* z, float* out)
{
  _mm256_storeu_ps (out, avx2::kinectNoiseAtNormalIncidence (_mm256_loadu_ps (z)));
}

TEST (VectorKernels, NoiseModelLanesAreTheScalarOne)
{
  // One noise model: the float form every kernel uses is the double model at θ = 0 to
  // float precision, and its eight-lane version is bit for bit the scalar one (ICP's
  // weights, the raycast's reach and propagation's bound use them in both paths).
  std::mt19937 rng (5);
  std::uniform_real_distribution<float> depth (0.f, 12.f);
  for (int round = 0; round < 1000; ++round)
  {
    float z[8], lanes[8] = {};
    for (float& d : z)
      d = depth (rng);
    for (const float d : z)
      ASSERT_NEAR (KinectNoiseModel::atNormalIncidence (d), kinectAxialNoise (d, 0.0), 1e-6 * kinectAxialNoise (d, 0.0)) << d;
    if (!cpuHasAvx2Fma ())
      continue;
    noiseLanes (z, lanes);
    for (int i = 0; i < 8; ++i)
      ASSERT_EQ (lanes[i], KinectNoiseModel::atNormalIncidence (z[i])) << "depth " << z[i];
  }
}
#endif

TEST (NormalMap, IsTheRenderersNormalOnFacesAndOneSidedAtOutlines)
{
  // Exact depth of the sphere and the box: inside a flat face (every neighbour at ±step on
  // the same plane, and within the depth-edge test) the central difference is the face's normal; at an outline, where one
  // side is background, the one-sided difference on the other side still gives one; holes
  // and the border have none. Both spans the project uses: tracking's ±1, the
  // segmentation's ±4.
  const simulation::SyntheticScene scene = test::sphereAndBoxScene (320, 240);
  const simulation::RenderedView view = simulation::SceneRenderer (scene).render (scene.camera, scene.trajectory.poseAt (0.1));
  cv::Mat vertices;
  computeVertexMap (view.depth, scene.camera, vertices);
  for (const int step : {1, 4})
  {
    NormalMapConfig config;
    config.step = step;
    config.max_depth_jump = 0.02f;
    cv::Mat normals;
    computeNormalMap (vertices, normals, config);
    ASSERT_EQ (normals.type (), CV_32FC3);
    ASSERT_EQ (normals.size (), vertices.size ());
    const auto truth = [&] (int x, int y) { return Eigen::Vector3f (&view.normals.at<cv::Vec3f> (y, x)[0]); };
    const auto onObject = [&] (int x, int y) { return view.instance.at<std::uint16_t> (y, x) != 0; };
    int face = 0, outline = 0;
    float worst_face = 0.f, worst_outline = 0.f;
    for (int y = 0; y < vertices.rows; ++y)
      for (int x = 0; x < vertices.cols; ++x)
      {
        const Eigen::Vector3f n = vertexAt (normals, x, y);
        const bool inside = x >= step && y >= step && x + step < vertices.cols && y + step < vertices.rows;
        if (!inside || view.depth.at<float> (y, x) <= 0.f)
        {
          ASSERT_FALSE (isValidVertex (n)) << "a normal without a point at (" << x << ", " << y << ") step " << step;
          continue;
        }
        if (!onObject (x, y))
          continue;
        const int sides[4][2] = {{-step, 0}, {step, 0}, {0, -step}, {0, step}};
        int same_face = 0, object_sides_h = 0, object_sides_v = 0, background = 0;
        for (int k = 0; k < 4; ++k)
        {
          const int u = x + sides[k][0], v = y + sides[k][1];
          const float z = view.depth.at<float> (y, x), dz = std::abs (view.depth.at<float> (v, u) - z);
          if (onObject (u, v) && view.instance.at<std::uint16_t> (v, u) == view.instance.at<std::uint16_t> (y, x))
          {
            (k < 2 ? object_sides_h : object_sides_v) += 1;
            // The same plane, and not so steep that the step looks like a depth edge.
            same_face += (truth (u, v) - truth (x, y)).norm () < 1e-4f && dz < 0.9f * config.max_depth_jump * z ? 1 : 0;
          }
          else
            background += view.depth.at<float> (v, u) <= 0.f || view.depth.at<float> (v, u) > 1.2f * view.depth.at<float> (y, x);
        }
        if (same_face == 4)
        {
          ASSERT_TRUE (isValidVertex (n)) << "face pixel (" << x << ", " << y << ") step " << step;
          worst_face = std::max (worst_face, (n - truth (x, y)).norm ());
          ++face;
        }
        else if (background > 0 && same_face == object_sides_h + object_sides_v && object_sides_h > 0 && object_sides_v > 0)
        {
          // An outline on a flat face: the background side is left out.
          ASSERT_TRUE (isValidVertex (n)) << "outline pixel (" << x << ", " << y << ") step " << step;
          worst_outline = std::max (worst_outline, (n - truth (x, y)).norm ());
          ++outline;
        }
      }
    EXPECT_GT (face, 2000) << "step " << step;
    EXPECT_GT (outline, 50) << "step " << step;
    EXPECT_LT (worst_face, 2e-3f) << "step " << step;      // ≈ 0.1°
    EXPECT_LT (worst_outline, 2e-3f) << "step " << step;
  }
}

TEST (VectorKernels, ModelPyramidIsTheScalarOne)
{
  if (!cpuHasAvx2Fma ())
    GTEST_SKIP () << "this CPU has no AVX2/FMA: only the scalar kernels run";
  // Vertex and normal maps of a view with holes (invalid vertices), invalid normals at the
  // outlines and depth jumps inside 2×2 blocks; 2 · 157 px wide, so rows end in a scalar
  // tail. The kernel sums and divides in the scalar order: results agree to the bit.
  const simulation::SyntheticScene scene = test::sphereAndBoxScene (314, 240);
  const simulation::RenderedView view = viewsWithHoles (scene, 1).front ();
  cv::Mat vertices, normals;
  computeVertexMap (view.depth, scene.camera, vertices);
  computeNormalMap (vertices, normals);
  cv::Mat half_vertices[2], half_normals[2];
  for (const bool vector : {false, true})
  {
    const KernelChoice choice (vector);
    downsampleVertexNormalMaps (vertices, normals, half_vertices[vector], half_normals[vector], 0.02f);
  }
  ASSERT_EQ (half_vertices[0].size (), cv::Size (157, 120));
  int valid = 0, invalid = 0, differing = 0;
  for (int y = 0; y < 120; ++y)
    for (int x = 0; x < 157; ++x)
    {
      const cv::Vec3f a = half_vertices[0].at<cv::Vec3f> (y, x), b = half_vertices[1].at<cv::Vec3f> (y, x);
      const cv::Vec3f m = half_normals[0].at<cv::Vec3f> (y, x), n = half_normals[1].at<cv::Vec3f> (y, x);
      if (std::isnan (a[0]))
      {
        ++invalid;
        differing += !(std::isnan (b[0]) && std::isnan (n[0]) && std::isnan (m[0]));
        continue;
      }
      ++valid;
      differing += std::memcmp (&a, &b, sizeof a) != 0 || std::memcmp (&m, &n, sizeof m) != 0;
    }
  EXPECT_GT (valid, 1500);
  EXPECT_GT (invalid, 1000);
  EXPECT_EQ (differing, 0);
}

TEST (VectorKernels, HintedRaycastIsTheScalarOne)
{
  if (!cpuHasAvx2Fma ())
    GTEST_SKIP () << "this CPU has no AVX2/FMA: only the scalar kernels run";
  // 317 px wide: each row ends in pixels the eight-ray kernel leaves to the scalar path.
  const simulation::SyntheticScene scene = test::sphereAndBoxScene (317, 240);
  const std::vector<simulation::RenderedView> views = viewsWithHoles (scene, 6);
  const TSDFVolume volume = integrateWith (false, scene, views);
  const Eigen::Isometry3d pose = scene.trajectory.poseAt (1.0 / 6.0);
  RaycastResult result[2];
  for (const bool vector : {false, true})
  {
    const KernelChoice choice (vector);
    volume.raycast (scene.camera, pose, result[vector], test::withHint (views[1].depth));
  }
  int hits = 0, only_one = 0, far = 0, colors_differ = 0;
  float worst_normal = 0.f;
  for (int y = 0; y < scene.camera.height; ++y)
    for (int x = 0; x < scene.camera.width; ++x)
    {
      const cv::Vec3f a = result[0].vertices.at<cv::Vec3f> (y, x), b = result[1].vertices.at<cv::Vec3f> (y, x);
      if (std::isnan (a[0]) != std::isnan (b[0]))
      {
        ++only_one;
        continue;
      }
      if (std::isnan (a[0]))
        continue;
      ++hits;
      far += cv::norm (a - b) > 1e-4;  // 0.1 mm
      worst_normal = std::max (worst_normal, static_cast<float> (cv::norm (result[0].normals.at<cv::Vec3f> (y, x) -
                                                                           result[1].normals.at<cv::Vec3f> (y, x))));
      colors_differ += result[0].colors.at<cv::Vec3b> (y, x) != result[1].colors.at<cv::Vec3b> (y, x);
    }
  ASSERT_GT (hits, 5000);
  EXPECT_LT (only_one, hits / 1000 + 1);
  EXPECT_LT (far, hits / 1000 + 1);
  EXPECT_LT (worst_normal, 1e-3f);
  EXPECT_LT (colors_differ, hits / 1000 + 1);
}

TEST (DepthSmoothing, NoiseAdaptiveBilateralIsOpenCVsFilterInNoiseUnits)
{
  // noiseAdaptiveBilateral filters depth mapped to noise units u(z) = atan(√(b/a)(z − z0)) /
  // √(ab) (σ_z(z) = a + b (z − z0)², Kinect) with its own bilateral filter; it must be
  // cv::bilateralFilter's (window, weights, reflected border) in both kernels. Reference:
  // the exact mapping, OpenCV's filter, the exact inverse.
  constexpr double a = 0.0012, b = 0.0019, z0 = 0.4;
  const auto to_units = [&] (double z) { return std::atan (std::sqrt (b / a) * (z - z0)) / std::sqrt (a * b); };
  const auto to_depth = [&] (double u) { return z0 + std::tan (u * std::sqrt (a * b)) / std::sqrt (b / a); };
  const int width = 97, height = 61;  // not multiples of eight: the vector rows' tails
  cv::Mat depth (height, width, CV_32F);
  std::mt19937 rng (7);
  std::normal_distribution<float> noise (0.f, 1.f);
  std::uniform_real_distribution<float> uniform (0.f, 1.f);
  for (int y = 0; y < height; ++y)
    for (int x = 0; x < width; ++x)
    {
      // A slanted plane at 1–3 m, a box 40 cm in front of it, Kinect noise and holes.
      float z = 1.f + 2.f * static_cast<float> (x) / width;
      if (x > 30 && x < 60 && y > 20 && y < 45)
        z -= 0.4f;
      z += static_cast<float> (kinectAxialNoise (z, 0.0)) * noise (rng);
      const float hole = uniform (rng);
      depth.at<float> (y, x) = hole < 0.03f ? 0.f : hole < 0.05f ? std::numeric_limits<float>::quiet_NaN () : z;
    }
  const float range_sigma = 8.f, sigma_space = 4.5f;
  const float invalid = static_cast<float> (to_units (0.0)) - 20.f * range_sigma;
  cv::Mat units (depth.size (), CV_32F), smoothed;
  for (int y = 0; y < height; ++y)
    for (int x = 0; x < width; ++x)
    {
      const float z = depth.at<float> (y, x);
      units.at<float> (y, x) = z > 0.f ? static_cast<float> (to_units (z)) : invalid;
    }
  cv::bilateralFilter (units, smoothed, 5, range_sigma, sigma_space);
  cv::Mat filtered[2];
  for (const bool vector : {false, true})
  {
    if (vector && !cpuHasAvx2Fma ())
      continue;
    const KernelChoice choice (vector);
    noiseAdaptiveBilateral (depth, 5, range_sigma, sigma_space, filtered[vector]);
    double worst = 0.0, moved = 0.0;
    int valid = 0;
    for (int y = 0; y < height; ++y)
      for (int x = 0; x < width; ++x)
      {
        const float z = depth.at<float> (y, x), out = filtered[vector].at<float> (y, x);
        if (!(z > 0.f))
        {
          EXPECT_EQ (out, 0.f) << "holes stay holes";
          continue;
        }
        ++valid;
        worst = std::max (worst, std::abs (out - to_depth (smoothed.at<float> (y, x))));
        moved = std::max (moved, static_cast<double> (std::abs (out - z)));
      }
    ASSERT_GT (valid, width * height * 9 / 10);
    EXPECT_LT (worst, 2e-5) << (vector ? "vector" : "scalar") << " kernel, metres";
    EXPECT_GT (moved, 1e-3) << "the filter must smooth the noise";
  }
  if (cpuHasAvx2Fma ())
  {
    double differs = 0.0;
    for (int y = 0; y < height; ++y)
      for (int x = 0; x < width; ++x)
        differs = std::max (differs, static_cast<double> (std::abs (filtered[0].at<float> (y, x) - filtered[1].at<float> (y, x))));
    EXPECT_LT (differs, 1e-5) << "scalar and vector kernels, metres";
  }
}
