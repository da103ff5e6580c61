// SPDX-License-Identifier: BSD-3-Clause
#include "test_utils.h"

#include <cuefusion/common/exceptions.h>
#include <cuefusion/io/dataset_layouts.h>
#include <cuefusion/io/file_io.h>
#include <cuefusion/io/pose_io.h>

#include <boost/filesystem.hpp>
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>

using namespace cuefusion;

namespace
{
/** A TUM folder with 2×2 images at the given stamps (depth value = 1 m). */
void
makeTum (const std::string& dir, const std::vector<std::string>& rgb, const std::vector<std::string>& depth)
{
  boost::filesystem::create_directories (dir + "/rgb");
  boost::filesystem::create_directories (dir + "/depth");
  std::string rgb_txt = "# timestamp filename\n", depth_txt;
  for (const std::string& t : rgb)
  {
    io::writeImageAtomic (dir + "/rgb/" + t + ".png", cv::Mat (2, 2, CV_8UC3, cv::Scalar (1, 2, 3)));
    rgb_txt += t + " rgb/" + t + ".png\n";
  }
  for (const std::string& t : depth)
  {
    io::writeImageAtomic (dir + "/depth/" + t + ".png", cv::Mat (2, 2, CV_16U, cv::Scalar (5000)));
    depth_txt += t + " depth/" + t + ".png\n";
  }
  test::writeFile (dir + "/rgb.txt", rgb_txt);
  test::writeFile (dir + "/depth.txt", depth_txt);
  test::writeFile (dir + "/intrinsics.txt", "2 2 0.5 0.5 2 2\n");
}

std::vector<std::string>
pairsOf (const io::DatasetGrabber& g)
{
  std::vector<std::string> out;
  for (const io::FrameRecord& r : g.records ())
    out.push_back (boost::filesystem::path (r.color_path).stem ().string () + "|" +
                   boost::filesystem::path (r.depth_path).stem ().string ());
  return out;
}
}  // namespace

TEST (TumAssociation, NearestWithinToleranceEachImageOnce)
{
  test::TempDir dir;
  makeTum (dir / "a", {"1.000", "1.100", "1.200"}, {"1.005", "1.190", "1.300"});
  io::TumGrabber g (dir / "a");
  EXPECT_EQ (pairsOf (g), (std::vector<std::string>{"1.000|1.005", "1.200|1.190"}));
  EXPECT_NEAR (g.readFrame (1)->depth.at<float> (0, 0), 1.0f, 1e-6);

  // Two colour images compete for one depth image: the closer pair wins.
  makeTum (dir / "b", {"2.000", "2.010"}, {"2.006"});
  EXPECT_EQ (pairsOf (io::TumGrabber (dir / "b")), (std::vector<std::string>{"2.010|2.006"}));

  // A wider tolerance admits a 95 ms pair.
  makeTum (dir / "c", {"3.000", "3.100"}, {"3.005", "3.195"});
  EXPECT_EQ (pairsOf (io::TumGrabber (dir / "c")).size (), 1u);
  io::TumGrabberConfig wide;
  wide.max_difference = 0.1;
  EXPECT_EQ (pairsOf (io::TumGrabber (dir / "c", wide)), (std::vector<std::string>{"3.000|3.005", "3.100|3.195"}));
}

TEST (TumAssociation, NothingWithinToleranceIsAnError)
{
  test::TempDir dir;
  makeTum (dir / "a", {"1.000"}, {"1.500"});
  EXPECT_THROW (io::TumGrabber (dir / "a"), Error);
}

TEST (TumGroundTruth, InterpolatedToFrameTimes)
{
  test::TempDir dir;
  makeTum (dir / "a", {"0.100", "0.200", "3.000"}, {"0.100", "0.200", "3.000"});
  // Identity at t = 0; at t = 0.4: 90° about z and 1 m along x. Nothing after t = 0.4.
  test::writeFile (dir / "a/groundtruth.txt",
                   "# timestamp tx ty tz qx qy qz qw\n0.0 0 0 0 0 0 0 1\n0.4 1 0 0 0 0 0.70710678118654752 "
                   "0.70710678118654752\n");
  io::TumGrabber g (dir / "a");
  ASSERT_EQ (g.size (), 3u);
  const RGBDFrame::Ptr quarter = g.readFrame (0);
  ASSERT_TRUE (quarter->pose.has_value ());
  EXPECT_NEAR (quarter->pose->translation ().x (), 0.25, 1e-12);
  const Eigen::AngleAxisd aa (quarter->pose->rotation ());
  EXPECT_NEAR (aa.angle (), M_PI / 8.0, 1e-9);
  EXPECT_NEAR (aa.axis ().z (), 1.0, 1e-9);
  EXPECT_NEAR (Eigen::AngleAxisd (g.readFrame (1)->pose->rotation ()).angle (), M_PI / 4.0, 1e-9);
  EXPECT_FALSE (g.readFrame (2)->pose.has_value ());  // 2 s past the last entry
}

TEST (TumGroundTruth, GapsAreNotBridged)
{
  io::Trajectory t (2);
  t[1].timestamp = 10.0;
  EXPECT_FALSE (io::interpolatePose (t, 5.0).has_value ());
  EXPECT_TRUE (io::interpolatePose (t, 5.0, 20.0).has_value ());
  EXPECT_TRUE (io::interpolatePose (t, 10.01).has_value ());   // within the extrapolation slack
  EXPECT_FALSE (io::interpolatePose (t, -0.5).has_value ());
}

TEST (TumFileLists, UnsortedOrDuplicateTimestampsAreErrors)
{
  test::TempDir dir;
  makeTum (dir / "a", {"1.000", "1.100"}, {"1.000", "1.100"});
  test::writeFile (dir / "a/rgb.txt", "1.100 rgb/1.100.png\n1.000 rgb/1.000.png\n");
  test::expectError ([&] { io::TumGrabber g (dir / "a"); }, "rgb.txt:2", "not sorted");
  test::writeFile (dir / "a/rgb.txt", "1.000 rgb/1.000.png\n1.100 rgb/1.100.png\n");
  test::writeFile (dir / "a/depth.txt", "1.000 depth/1.000.png\n1.000 depth/1.100.png\n");
  test::expectError ([&] { io::TumGrabber g (dir / "a"); }, "depth.txt:2", "duplicate timestamp");
  test::writeFile (dir / "a/depth.txt", "1.000 depth/1.000.png\n1.100 depth/1.100.png\n");
  test::writeFile (dir / "a/groundtruth.txt", "1.0 0 0 0 0 0 0 1\n0.5 0 0 0 0 0 0 1\n");
  EXPECT_THROW (io::TumGrabber (dir / "a"), Error);
}

TEST (TumAssociation, ManyStampsWithinTheToleranceAreAssociatedInLinearTime)
{
  // 20,000 colour and 20,000 depth stamps, all within 10 ms: every pair is within the
  // tolerance, so weighing every pair (400 million) runs out of memory. Each depth image
  // follows its colour image by 0.1 µs and precedes the next by 0.4 µs: nearest pairs are
  // (i, i).
  test::TempDir dir;
  boost::filesystem::create_directories (dir / "a");
  std::string rgb_txt, depth_txt;
  char line[96];
  const int n = 20000;
  for (int i = 0; i < n; ++i)
  {
    std::snprintf (line, sizeof line, "%.7f rgb/%d.png\n", 100.0 + 5e-7 * i, i);
    rgb_txt += line;
    std::snprintf (line, sizeof line, "%.7f depth/%d.png\n", 100.0 + 5e-7 * i + 1e-7, i);
    depth_txt += line;
  }
  test::writeFile (dir / "a/rgb.txt", rgb_txt);
  test::writeFile (dir / "a/depth.txt", depth_txt);
  test::writeFile (dir / "a/intrinsics.txt", "2 2 0.5 0.5 2 2\n");
  const io::TumGrabber g (dir / "a");
  const std::vector<std::string> pairs = pairsOf (g);
  ASSERT_EQ (pairs.size (), static_cast<std::size_t> (n));
  for (int i = 0; i < n; i += 997)
    EXPECT_EQ (pairs[static_cast<std::size_t> (i)], std::to_string (i) + "|" + std::to_string (i));
}
