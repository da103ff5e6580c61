// SPDX-License-Identifier: BSD-3-Clause
#include "reconstruction_fixtures.h"

#include <cuefusion/reconstruction/dense_reconstruction.h>
#include <cuefusion/reconstruction/texture_agreement.h>
#include <cuefusion/reconstruction/vertex_maps.h>

#include <gtest/gtest.h>

#include <cmath>
#include <random>

using namespace cuefusion;

TEST (TextureAgreement, TheRightPoseLinesUpAndAPoseAFewCentimetresOrDegreesOffDoesNot)
{
  // The printed tabletop fused from six views of its first 30° of orbit; views drawn in that
  // arc, rendered and compared with the model raycast at their own pose, then at that pose
  // moved 3 cm sideways or turned 3° (ICP could not tell those apart where the view sees a
  // table top alone; the texture can). The threshold relocalisation uses lies between, and
  // the right pose is the peak over moves of 4 cm (relocalisation_confirmation_shift).
  const std::string path = test::tabletopScenePath ();
  simulation::SyntheticScene scene = simulation::SyntheticScene::parse (test::printedSceneText (path), "tabletop printed");
  scene.camera = scene.camera.scaled (320, 240);
  const simulation::SceneRenderer renderer (scene);
  reconstruction::TSDFVolume volume;
  const double arc = 30.0 / scene.trajectory.sweep_deg;  // the fraction of poseAt's range that is 30°
  for (int i = 0; i < 6; ++i)
  {
    const Eigen::Isometry3d pose = scene.trajectory.poseAt (arc * i / 5.0);
    const simulation::RenderedView view = renderer.render (scene.camera, pose);
    volume.integrate (view.depth, view.color, scene.camera, pose);
  }
  const double threshold = reconstruction::DenseReconstructionConfig ().relocalisation_min_texture_agreement;
  const double distance = reconstruction::ProjectiveICPConfig ().max_distance;
  std::mt19937 random (11);
  for (int draw = 0; draw < 4; ++draw)
  {
    const Eigen::Isometry3d pose = scene.trajectory.poseAt (std::uniform_real_distribution<double> (0.0, arc) (random));
    const simulation::RenderedView frame = renderer.render (scene.camera, pose);
    cv::Mat points;
    reconstruction::computeVertexMap (frame.depth, scene.camera, points);
    const reconstruction::RaycastResult model = test::rendered (volume, scene.camera, pose);
    const reconstruction::TexturePeak right = reconstruction::texturePeak (frame.color, points, model, pose, 0.04, distance, 300);
    EXPECT_GE (right.agreement, threshold) << "draw " << draw;
    EXPECT_TRUE (right.peak) << "draw " << draw;
    EXPECT_EQ (right.agreement, reconstruction::textureAgreement (frame.color, points, model, pose, distance, 300));
    const double angle = std::uniform_real_distribution<double> (0.0, 2.0 * M_PI) (random);
    Eigen::Isometry3d moved = pose, turned = pose;
    moved.translation () += pose.linear () * Eigen::Vector3d (0.03 * std::cos (angle), 0.03 * std::sin (angle), 0.0);
    turned.linear () = pose.linear () * Eigen::AngleAxisd (3.0 * M_PI / 180.0, Eigen::Vector3d (std::cos (angle), std::sin (angle), 0.0)).toRotationMatrix ();
    for (const Eigen::Isometry3d& wrong : {moved, turned})
    {
      const reconstruction::RaycastResult there = test::rendered (volume, scene.camera, wrong);
      const reconstruction::TexturePeak off = reconstruction::texturePeak (frame.color, points, there, wrong, 0.04, distance, 300);
      EXPECT_LT (off.agreement, threshold) << "draw " << draw;
      EXPECT_FALSE (off.peak && off.agreement >= threshold) << "draw " << draw;
    }
    // Nothing to judge by: a frame without texture, or too few points on the model.
    const cv::Mat flat (frame.color.size (), CV_8UC3, cv::Scalar::all (128));
    EXPECT_TRUE (std::isnan (reconstruction::textureAgreement (flat, points, model, pose, distance, 300)));
    EXPECT_FALSE (reconstruction::texturePeak (flat, points, model, pose, 0.04, distance, 300).peak);
    EXPECT_TRUE (std::isnan (reconstruction::textureAgreement (frame.color, points, model, pose, distance, 1u << 20)));
  }
}
