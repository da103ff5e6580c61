// SPDX-License-Identifier: BSD-3-Clause
// Every kind of bad input gives a cuefusion::Error whose one-line message names the
// file and what is wrong; none crashes.
#include "synthetic_fixtures.h"

#include <cuefusion/common/exceptions.h>
#include <cuefusion/io/sequence.h>
#include <cuefusion/simulation/synthetic_sequence.h>

#include <boost/filesystem.hpp>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <gtest/gtest.h>

using namespace cuefusion;
namespace fs = boost::filesystem;

namespace
{
class BadInput : public ::testing::Test
{
protected:
  void
  SetUp () override
  {
    const simulation::SyntheticSequence seq = test::smallTabletop (3, 64, 48);
    simulation::writeSyntheticSequence (seq, io::DatasetLayout::SevenScenes, dir / "7s");
    simulation::writeSyntheticSequence (seq, io::DatasetLayout::Redwood, dir / "redwood");
    simulation::writeSyntheticSequence (seq, io::DatasetLayout::ScanNet, dir / "scannet");
  }

  test::TempDir dir;
};
}  // namespace

TEST_F (BadInput, MissingEmptyAndUnrecognisedFolders)
{
  test::expectError ([&] { io::openDataset (dir / "nope"); }, dir / "nope", "no such file or folder");
  fs::create_directories (dir / "empty");
  test::expectError ([&] { io::openDataset (dir / "empty"); }, dir / "empty", "folder is empty");
  test::writeFile (dir / "empty/readme.txt", "hello");
  test::expectError ([&] { io::openDataset (dir / "empty"); }, dir / "empty", "unrecognised sequence layout");
  test::expectError ([&] { io::openDataset (dir / "empty/readme.txt"); }, "readme.txt", "not a folder");
  test::expectError ([&] { io::openSequence (dir / "missing.oni"); }, "missing.oni", "no such .oni recording");
}

TEST_F (BadInput, CorruptAndTruncatedImages)
{
  const io::DatasetGrabber::Ptr g = io::openDataset (dir / "7s");
  const std::string depth = dir / "7s/frame-000001.depth.png";
  const std::string bytes = test::readFile (depth);
  test::writeFile (depth, bytes.substr (0, bytes.size () - 30));
  test::expectError ([&] { g->readFrame (1); }, "frame-000001.depth.png", "truncated");
  test::writeFile (depth, "garbage");
  test::expectError ([&] { g->readFrame (1); }, "frame-000001.depth.png", "cannot decode");
  const std::string color = dir / "7s/frame-000002.color.png";
  test::writeFile (color, "");
  test::expectError ([&] { g->readFrame (2); }, "frame-000002.color.png", "empty");
  EXPECT_NO_THROW (g->readFrame (0));
}

TEST_F (BadInput, DepthSizeDiffersFromIntrinsics)
{
  test::writeFile (dir / "redwood/camera_intrinsics.json",
                   "{\"width\": 640, \"height\": 480, \"intrinsic_matrix\": [525,0,0,0,525,0,319.5,239.5,1]}");
  const io::DatasetGrabber::Ptr g = io::openDataset (dir / "redwood");
  test::expectError ([&] { g->readFrame (0); }, "00000.png", "depth image is 64x48 but the intrinsics are for 640x480");
}

TEST_F (BadInput, MissingIntrinsics)
{
  fs::remove (dir / "7s/camera-intrinsics.txt");
  test::expectError ([&] { io::openDataset (dir / "7s"); }, "camera-intrinsics.txt", "missing intrinsics");
  fs::remove (dir / "scannet/intrinsic/intrinsic_depth.txt");
  test::expectError ([&] { io::openDataset (dir / "scannet"); }, "intrinsic_depth.txt", "missing intrinsics");
  test::writeFile (dir / "redwood/camera_intrinsics.json", "{\"width\": 640");
  test::expectError ([&] { io::openDataset (dir / "redwood"); }, "camera_intrinsics.json", "not valid JSON");
}

TEST_F (BadInput, PoseThatIsNot4x4)
{
  test::writeFile (dir / "7s/frame-000001.pose.txt", "1 0 0 0\n0 1 0 0\n0 0 1 0\n");
  const io::DatasetGrabber::Ptr g = io::openDataset (dir / "7s");
  test::expectError ([&] { g->readFrame (1); }, "frame-000001.pose.txt", "expected a 4x4 pose matrix (16 numbers), found 12");
  test::writeFile (dir / "7s/frame-000001.pose.txt", "1 0 0 0\n0 1 0 0\n0 0 1 x\n0 0 0 1\n");
  test::expectError ([&] { g->readFrame (1); }, "frame-000001.pose.txt", "not a number");
  test::writeFile (dir / "redwood/trajectory.log", "0 0 1\n1 0 0 0\n0 1 0 0\n0 0 1 0\n");
  test::expectError ([&] { io::openDataset (dir / "redwood"); }, "trajectory.log", "inside a 4x4 matrix");
}

TEST_F (BadInput, MismatchedCounts)
{
  fs::remove (dir / "redwood/image/00002.png");
  test::expectError ([&] { io::openDataset (dir / "redwood"); }, "redwood", "3 depth images but 2 colour images");
  fs::remove (dir / "7s/frame-000001.color.png");
  test::expectError ([&] { io::openDataset (dir / "7s"); }, "frame-000001", "missing colour image");
}

TEST_F (BadInput, RedwoodPairsColourAndDepthByFrameNotBySortPosition)
{
  // Equal counts, one colour frame missing and another extra: by sort position depth 00001
  // would take colour 00002 and every later frame its neighbour's colour.
  fs::rename (dir / "redwood/image/00001.png", dir / "redwood/image/00003.png");
  test::expectError ([&] { io::openDataset (dir / "redwood"); }, "depth/00001.png", "no colour image of its frame in image/");
  // Redwood scans name a frame INDEX-STAMP with colour and depth stamps apart: the index pairs them.
  fs::rename (dir / "redwood/image/00003.png", dir / "redwood/image/00001.png");
  for (int i = 0; i < 3; ++i)
  {
    const std::string n = "0000" + std::to_string (i);
    fs::rename (dir / ("redwood/depth/" + n + ".png"), dir / ("redwood/depth/" + n + "-00000" + std::to_string (40 - 3 * i) + ".png"));
    fs::rename (dir / ("redwood/image/" + n + ".png"), dir / ("redwood/image/" + n + "-00000" + std::to_string (41 + i) + ".png"));
  }
  const io::DatasetGrabber::Ptr g = io::openDataset (dir / "redwood");
  const io::DatasetGrabber::Ptr seven = io::openDataset (dir / "7s");
  for (std::size_t i = 0; i < 3; ++i)
  {
    const cv::Mat a = g->readFrame (i)->color, b = seven->readFrame (i)->color;
    ASSERT_EQ (a.size (), b.size ());
    EXPECT_EQ (cv::norm (a, b, cv::NORM_INF), 0.0) << "frame " << i << " took another frame's colour";
  }
  // Two colour images of one frame: which one is meant is not for the reader to guess.
  fs::copy_file (dir / "redwood/image/00002-0000043.png", dir / "redwood/image/2.png");
  test::expectError ([&] { io::openDataset (dir / "redwood"); }, "image/", "names the same frame as");
}

TEST_F (BadInput, ColourOfAnotherAspectThanTheDepthIsRefused)
{
  const std::string color = dir / "7s/frame-000001.color.png";
  const cv::Mat original = cv::imread (color, cv::IMREAD_COLOR);
  ASSERT_EQ (original.cols * 48, original.rows * 64);  // the depth's aspect, at another resolution
  cv::Mat square;
  cv::resize (original, square, cv::Size (original.cols, original.cols));
  ASSERT_TRUE (cv::imwrite (color, square));
  const io::DatasetGrabber::Ptr g = io::openDataset (dir / "7s");
  test::expectError ([&] { g->readFrame (1); }, "frame-000001.color.png", "another aspect than the depth's 64x48");
  EXPECT_NO_THROW (g->readFrame (0));
}

TEST_F (BadInput, SyntheticOutputIsNeverHalfWritten)
{
  const simulation::SyntheticSequence seq = test::smallTabletop (2, 32, 24);
  // An existing sequence is not overwritten by accident...
  test::expectError ([&] { simulation::writeSyntheticSequence (seq, io::DatasetLayout::TUM, dir / "7s"); }, "7s", "already exists");
  EXPECT_TRUE (fs::exists (dir / "7s/frame-000002.depth.png"));
  // ...and replaced whole when asked.
  simulation::writeSyntheticSequence (seq, io::DatasetLayout::TUM, dir / "7s", true);
  EXPECT_EQ (io::openDataset (dir / "7s")->formatName (), "tum");
  EXPECT_FALSE (fs::exists (dir / "7s/frame-000002.depth.png"));
}
