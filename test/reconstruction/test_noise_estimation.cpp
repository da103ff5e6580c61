// SPDX-License-Identifier: BSD-3-Clause
// estimateDepthNoise against the noise the generator draws (exact σ_z of each sensor model).
#include <cuefusion/common/exceptions.h>
#include <cuefusion/common/pinhole_camera.h>
#include <cuefusion/simulation/scene_renderer.h>
#include <cuefusion/simulation/synthetic_scene.h>
#include <cuefusion/reconstruction/noise_estimation.h>

#include <gtest/gtest.h>

#include <limits>
#include <random>
#include <string>

using namespace cuefusion;

namespace
{
/** A grey wall filling the view, its front face at depth \a z. */
simulation::SyntheticScene
wallAt (double z)
{
  return simulation::SyntheticScene::parse ("object wall color=200,200,200\n box center=0,0," + std::to_string (z + 0.05) +
                                    " size=30,30,0.1\n", "wall.scene");
}

cv::Mat
renderWall (double z, const simulation::DepthNoiseConfig& noise, unsigned seed, double pitch = 0.0)
{
  const PinholeCamera camera (262.5, 262.5, 159.5, 119.5, 320, 240);
  // The camera pitched by \a pitch looks at the wall obliquely: a plane in depth that is
  // not fronto-parallel, which a fit in inverse depth takes exactly.
  const Eigen::Isometry3d pose (Eigen::AngleAxisd (pitch, Eigen::Vector3d::UnitX ()));
  return simulation::SceneRenderer (wallAt (z)).render (camera, pose, noise, seed).depth;
}
}  // namespace

TEST (DepthNoise, ExactDepthOfATiltedPlaneHasNone)
{
  const simulation::DepthNoiseConfig off;
  for (double pitch : {0.0, 0.5})
  {
    const reconstruction::DepthNoiseEstimate estimate = reconstruction::estimateDepthNoise (renderWall (1.7, off, 1, pitch));
    EXPECT_GT (estimate.patches, 1000) << pitch;
    EXPECT_LT (estimate.ratio, 0.05) << "exact depth, pitch " << pitch;
  }
}

TEST (DepthNoise, EachSensorModelsNoiseIsMeasuredAsItsRatioToKinects)
{
  // Walls at depths drawn over 0.8–3.5 m, seen head-on and at 30°: the Kinect model reads
  // 1 (its own σ_z), the RealSense-like model its σ_z over Kinect's at that depth.
  std::mt19937 draw (7);
  simulation::DepthNoiseConfig kinect;
  kinect.enabled = true;
  simulation::DepthNoiseConfig stereo = kinect;
  stereo.sensor = simulation::DepthSensor::RealSense;
  for (int k = 0; k < 3; ++k)
  {
    const double z = std::uniform_real_distribution<double> (0.8, 3.5) (draw);
    const double pitch = k == 2 ? 0.5 : 0.0;
    const float kinect_ratio = reconstruction::estimateDepthNoise (renderWall (z, kinect, 3 + k, pitch)).ratio;
    EXPECT_NEAR (kinect_ratio, 1.0, 0.1) << "Kinect model, wall at " << z << " m";
    if (pitch != 0.0)
      continue;  // the stereo model's σ_z at one depth: head-on walls only
    const double expected = simulation::stereoAxialNoise (z, 525.0, stereo) / KinectNoiseModel::atNormalIncidence (static_cast<float> (z));
    const float stereo_ratio = reconstruction::estimateDepthNoise (renderWall (z, stereo, 3 + k)).ratio;
    EXPECT_NEAR (stereo_ratio, expected, 0.1 * expected) << "RealSense-like model, wall at " << z << " m";
  }
}

TEST (DepthNoise, AnImageWithoutSurfaceMeasuresNothingAndAWrongTypeThrows)
{
  cv::Mat empty (240, 320, CV_32F, cv::Scalar (0.f));
  empty (cv::Rect (0, 0, 20, 20)).setTo (cv::Scalar (std::numeric_limits<float>::quiet_NaN ()));
  const reconstruction::DepthNoiseEstimate estimate = reconstruction::estimateDepthNoise (empty);
  EXPECT_EQ (estimate.patches, 0);
  EXPECT_EQ (estimate.ratio, 0.f);
  EXPECT_THROW (reconstruction::estimateDepthNoise (cv::Mat (240, 320, CV_16U, cv::Scalar (1000))), Error);
  EXPECT_THROW (reconstruction::estimateDepthNoise (empty, 2), Error);
}
