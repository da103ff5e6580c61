// SPDX-License-Identifier: BSD-3-Clause
#include <cuefusion/common/exceptions.h>
#include <cuefusion/common/rgbd_frame.h>

#include <gtest/gtest.h>

#include <cmath>
#include <limits>

using cuefusion::RGBDFrame;

namespace
{
RGBDFrame
makeFrame ()
{
  RGBDFrame f;
  f.camera = cuefusion::PinholeCamera (100.0, 100.0, 1.5, 1.0, 4, 3);
  f.depth = cv::Mat (3, 4, CV_32F, cv::Scalar (2.0f));
  f.color = cv::Mat (3, 4, CV_8UC3, cv::Scalar (10, 20, 30));  // B, G, R
  f.depth.at<float> (0, 0) = 0.f;
  f.depth.at<float> (1, 2) = std::numeric_limits<float>::quiet_NaN ();
  return f;
}
}  // namespace

TEST (RGBDFrame, ToPointCloudIsOrganizedWithNaNForInvalidDepth)
{
  const RGBDFrame f = makeFrame ();
  const auto cloud = cuefusion::toPointCloud (f);
  ASSERT_EQ (cloud->width, 4u);
  ASSERT_EQ (cloud->height, 3u);
  EXPECT_TRUE (cloud->isOrganized ());
  EXPECT_FALSE (cloud->is_dense);
  EXPECT_TRUE (std::isnan ((*cloud) (0, 0).z));
  EXPECT_TRUE (std::isnan ((*cloud) (2, 1).x));
  const pcl::PointXYZRGBA& p = (*cloud) (3, 2);  // u = 3, v = 2
  EXPECT_FLOAT_EQ (p.z, 2.f);
  EXPECT_FLOAT_EQ (p.x, (3 - 1.5f) / 100.f * 2.f);
  EXPECT_FLOAT_EQ (p.y, (2 - 1.0f) / 100.f * 2.f);
  EXPECT_EQ (p.r, 30);
  EXPECT_EQ (p.g, 20);
  EXPECT_EQ (p.b, 10);
}

TEST (RGBDFrame, ValidateRejectsSizeMismatch)
{
  RGBDFrame f = makeFrame ();
  EXPECT_NO_THROW (f.validate ("frame"));
  f.camera.width = 5;
  EXPECT_THROW (f.validate ("frame"), cuefusion::Error);
  f = makeFrame ();
  f.instance_mask = cv::Mat (2, 2, CV_16U);
  EXPECT_THROW (f.validate ("frame"), cuefusion::Error);
}

TEST (RGBDFrame, FromOrganizedCloudRecoversDepthColourAndCamera)
{
  // A slanted surface seen by a known camera: the fit must give that camera back.
  RGBDFrame f;
  f.camera = cuefusion::PinholeCamera (520.0, 515.0, 318.0, 242.5, 64, 48);
  f.depth = cv::Mat (48, 64, CV_32F);
  f.color = cv::Mat (48, 64, CV_8UC3, cv::Scalar (10, 20, 30));
  for (int v = 0; v < 48; ++v)
    for (int u = 0; u < 64; ++u)
      f.depth.at<float> (v, u) = 1.f + 0.01f * u + 0.02f * v;
  f.depth.at<float> (5, 7) = 0.f;
  const RGBDFrame back = cuefusion::fromOrganizedCloud (*cuefusion::toPointCloud (f));
  EXPECT_NEAR (back.camera.fx, 520.0, 1e-2);
  EXPECT_NEAR (back.camera.fy, 515.0, 1e-2);
  EXPECT_NEAR (back.camera.cx, 318.0, 1e-2);
  EXPECT_NEAR (back.camera.cy, 242.5, 1e-2);
  EXPECT_EQ (back.camera.width, 64);
  EXPECT_EQ (back.depth.at<float> (5, 7), 0.f);
  EXPECT_FLOAT_EQ (back.depth.at<float> (40, 30), f.depth.at<float> (40, 30));
  EXPECT_EQ (back.color.at<cv::Vec3b> (3, 3), cv::Vec3b (10, 20, 30));

  // Nothing valid: Kinect's camera at the cloud's size, depth all 0.
  pcl::PointCloud<pcl::PointXYZRGBA> empty (8, 6);
  for (auto& p : empty)
    p.x = p.y = p.z = std::numeric_limits<float>::quiet_NaN ();
  const RGBDFrame none = cuefusion::fromOrganizedCloud (empty);
  EXPECT_EQ (none.camera.width, 8);
  EXPECT_EQ (cv::countNonZero (none.depth), 0);
}
