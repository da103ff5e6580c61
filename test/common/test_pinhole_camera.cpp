// SPDX-License-Identifier: BSD-3-Clause
#include <cuefusion/common/exceptions.h>
#include <cuefusion/common/pinhole_camera.h>

#include <gtest/gtest.h>

#include <cmath>

using cuefusion::PinholeCamera;

TEST (PinholeCamera, ProjectBackProjectRoundTrip)
{
  const PinholeCamera cam (585.0, 580.0, 320.0, 240.0, 640, 480);
  for (float u : {0.f, 13.25f, 320.f, 639.f})
    for (float v : {0.f, 200.5f, 479.f})
      for (float z : {0.4f, 1.7f, 6.0f})
      {
        const Eigen::Vector3f p = cam.backProject (u, v, z);
        EXPECT_FLOAT_EQ (p.z (), z);
        const Eigen::Vector2f uv = cam.project (p);
        EXPECT_NEAR (uv.x (), u, 1e-3);
        EXPECT_NEAR (uv.y (), v, 1e-3);
      }
}

TEST (PinholeCamera, ProjectToPixelRejectsOutsideAndBehind)
{
  const PinholeCamera cam (500, 500, 319.5, 239.5, 640, 480);
  int u, v;
  EXPECT_TRUE (cam.projectToPixel (cam.backProject (10.4f, 20.6f, 2.f), u, v));
  EXPECT_EQ (u, 10);
  EXPECT_EQ (v, 21);
  EXPECT_FALSE (cam.projectToPixel (Eigen::Vector3f (0, 0, -1), u, v));
  EXPECT_FALSE (cam.projectToPixel (cam.backProject (-3.f, 10.f, 1.f), u, v));
  EXPECT_FALSE (cam.projectToPixel (cam.backProject (10.f, 480.f, 1.f), u, v));
}

TEST (PinholeCamera, ScalingKeepsImageBordersAndRoundTrips)
{
  const PinholeCamera cam (525.0, 525.0, 319.5, 239.5, 640, 480);
  const PinholeCamera half = cam.scaled (320, 240);
  EXPECT_DOUBLE_EQ (half.fx, 262.5);
  EXPECT_DOUBLE_EQ (half.cx, 159.5);  // centre of a 320-wide image
  EXPECT_DOUBLE_EQ (half.cy, 119.5);
  // The left edge of pixel 0 (u = -0.5) stays the left edge at any resolution.
  const Eigen::Vector3f ray = cam.backProject (-0.5f, -0.5f, 1.f);
  const Eigen::Vector2f edge = half.project (ray);
  EXPECT_NEAR (edge.x (), -0.5f, 1e-5);
  EXPECT_NEAR (edge.y (), -0.5f, 1e-5);
  EXPECT_TRUE (half.scaled (640, 480) == cam);
}

TEST (PinholeCamera, ValidateNamesTheSource)
{
  PinholeCamera bad (0.0, 525.0, 319.5, 239.5, 640, 480);
  EXPECT_FALSE (bad.isValid ());
  try
  {
    bad.validate ("cam.txt");
    FAIL ();
  }
  catch (const cuefusion::Error& e)
  {
    EXPECT_EQ (std::string (e.what ()).rfind ("cam.txt: ", 0), 0u);
  }
  EXPECT_TRUE (PinholeCamera ().isValid ());
}

TEST (KinectNoise, MatchesNguyenModel)
{
  // At 0.4 m facing the sensor only the constant term remains.
  EXPECT_NEAR (cuefusion::kinectAxialNoise (0.4, 0.0), 0.0012, 1e-12);
  // 2 m, 60 degrees: 0.0012 + 0.0019·1.6² + 0.0001/√2 · (π/3)²/(π/6)² = 0.0012 + 0.004864 + 0.000282843
  EXPECT_NEAR (cuefusion::kinectAxialNoise (2.0, M_PI / 3.0), 0.0012 + 0.004864 + 0.0001 / std::sqrt (2.0) * 4.0, 1e-9);
  EXPECT_TRUE (std::isfinite (cuefusion::kinectAxialNoise (1.0, M_PI / 2.0)));
  EXPECT_GT (cuefusion::kinectAxialNoise (3.0, 0.0), cuefusion::kinectAxialNoise (1.0, 0.0));
}
