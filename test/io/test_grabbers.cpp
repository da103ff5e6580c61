// SPDX-License-Identifier: BSD-3-Clause
#include "synthetic_fixtures.h"

#include <cuefusion/common/exceptions.h>
#include <cuefusion/io/sequence.h>
#include <cuefusion/simulation/synthetic_sequence.h>

#include <gtest/gtest.h>

#include <chrono>
#include <thread>

using namespace cuefusion;

namespace
{
struct LayoutCase
{
  io::DatasetLayout layout;
  const char* format;
  double depth_units;    // units per metre in the layout's depth PNGs
  bool lossless_color;   // ScanNet stores JPEG at twice the resolution
};

// Readable test names in ctest's listing.
void
PrintTo (const LayoutCase& c, std::ostream* os)
{
  *os << c.format;
}

class GrabberReadBack : public ::testing::TestWithParam<LayoutCase>
{
protected:
  void
  SetUp () override
  {
    // Noise: invalid pixels and noisy depth must survive the round trip too.
    sequence = std::make_unique<simulation::SyntheticSequence> (test::smallTabletop (4, 160, 120, true, 3));
    simulation::writeSyntheticSequence (*sequence, GetParam ().layout, dir / "seq");
  }
  test::TempDir dir;
  std::unique_ptr<simulation::SyntheticSequence> sequence;
};
}  // namespace

TEST_P (GrabberReadBack, FramesPosesAndMasksMatchTheGenerator)
{
  const LayoutCase& c = GetParam ();
  EXPECT_EQ (io::toString (io::detectSequenceFormat (dir / "seq")), c.format);
  const io::DatasetGrabber::Ptr grabber = io::openDataset (dir / "seq");
  EXPECT_EQ (grabber->formatName (), c.format);
  ASSERT_EQ (grabber->size (), sequence->size ());
  EXPECT_TRUE (grabber->hasPoses ());
  EXPECT_TRUE (grabber->hasInstanceMasks ());
  const PinholeCamera& cam = grabber->camera ();
  EXPECT_EQ (cam.width, 160);
  EXPECT_EQ (cam.height, 120);
  EXPECT_NEAR (cam.fx, sequence->camera ().fx, 1e-9);
  EXPECT_NEAR (cam.cx, sequence->camera ().cx, 1e-9);
  EXPECT_NEAR (cam.cy, sequence->camera ().cy, 1e-9);

  for (std::size_t i = 0; i < sequence->size (); ++i)
  {
    const RGBDFrame::Ptr truth = sequence->frame (i);
    const RGBDFrame::Ptr read = grabber->readFrame (i);
    EXPECT_NO_THROW (read->validate ("read"));
    EXPECT_EQ (read->index, i);
    EXPECT_NEAR (read->timestamp - grabber->readFrame (0)->timestamp, truth->timestamp - 1.0, 1e-5);
    // Depth: exact up to the layout's quantisation; invalid stays invalid.
    int valid = 0;
    for (int v = 0; v < truth->depth.rows; ++v)
      for (int u = 0; u < truth->depth.cols; ++u)
      {
        const float z = truth->depth.at<float> (v, u);
        const float back = read->depth.at<float> (v, u);
        if (isValidDepth (z))
        {
          ++valid;
          ASSERT_NEAR (back, z, 0.5 / c.depth_units + 1e-6) << "pixel " << u << "," << v;
        }
        else
          ASSERT_EQ (back, 0.f);
      }
    EXPECT_GT (valid, truth->depth.total () / 2);
    if (c.lossless_color)
      EXPECT_EQ (cv::norm (read->color, truth->color, cv::NORM_INF), 0.0);
    else
      EXPECT_LT (cv::norm (read->color, truth->color, cv::NORM_L1) / (3.0 * truth->color.total ()), 3.0);
    ASSERT_TRUE (read->pose.has_value ());
    EXPECT_TRUE (read->pose->isApprox (*truth->pose, 1e-7)) << read->pose->matrix () << "\n" << truth->pose->matrix ();
    EXPECT_EQ (cv::norm (read->instance_mask, truth->instance_mask, cv::NORM_INF), 0.0);
    EXPECT_EQ (cv::norm (read->class_mask, truth->class_mask, cv::NORM_INF), 0.0);
  }
}

INSTANTIATE_TEST_SUITE_P (Layouts, GrabberReadBack,
                          ::testing::Values (LayoutCase{io::DatasetLayout::TUM, "tum", 5000.0, true},
                                             LayoutCase{io::DatasetLayout::ScanNet, "scannet", 1000.0, false},
                                             LayoutCase{io::DatasetLayout::Redwood, "redwood", 1000.0, true},
                                             LayoutCase{io::DatasetLayout::SevenScenes, "7scenes", 1000.0, true}),
                          [] (const ::testing::TestParamInfo<LayoutCase>& info) {
                            return std::string (info.param.format == std::string ("7scenes") ? "SevenScenes"
                                                                                              : info.param.format);
                          });

namespace
{
class GrabberModes : public ::testing::Test
{
protected:
  void
  SetUp () override
  {
    simulation::writeSyntheticSequence (test::smallTabletop (7, 64, 48), io::DatasetLayout::SevenScenes, dir / "seq");
  }
  test::TempDir dir;
};
}  // namespace

TEST_F (GrabberModes, TriggerModeEmitsEveryFrameOnceInOrder)
{
  const io::DatasetGrabber::Ptr grabber = io::openDataset (dir / "seq");
  std::vector<std::size_t> frames, clouds;
  grabber->registerCallback (std::function<io::RGBDGrabber::sig_cb_rgbd_frame> (
    [&] (const RGBDFrame::ConstPtr& f) { frames.push_back (f->index); }));
  grabber->registerCallback (std::function<io::RGBDGrabber::sig_cb_point_cloud_rgba> (
    [&] (const pcl::PointCloud<pcl::PointXYZRGBA>::ConstPtr& c) {
      EXPECT_EQ (c->width, 64u);
      EXPECT_EQ (c->height, 48u);
      clouds.push_back (c->header.seq);
    }));
  EXPECT_FALSE (grabber->trigger ());  // not started
  grabber->start ();
  while (grabber->trigger ())
  {
  }
  EXPECT_FALSE (grabber->isRunning ());
  const std::vector<std::size_t> expected = {0, 1, 2, 3, 4, 5, 6};
  EXPECT_EQ (frames, expected);
  EXPECT_EQ (clouds, expected);
  // A restart replays the sequence; a frame limit cuts it.
  frames.clear ();
  clouds.clear ();
  grabber->setFrameLimit (3);
  grabber->start ();
  while (grabber->trigger ())
  {
  }
  EXPECT_EQ (frames, (std::vector<std::size_t>{0, 1, 2}));
}

TEST_F (GrabberModes, RealTimeModePlaysInOrderAndStops)
{
  const io::DatasetGrabber::Ptr grabber = io::openDataset (dir / "seq");
  std::vector<std::size_t> frames;
  std::mutex m;
  grabber->registerCallback (std::function<io::RGBDGrabber::sig_cb_rgbd_frame> ([&] (const RGBDFrame::ConstPtr& f) {
    std::lock_guard<std::mutex> lock (m);
    frames.push_back (f->index);
  }));
  grabber->setFramesPerSecond (100.f);
  grabber->start ();
  // 7 frames at 100 fps take 70 ms; allow a generous bound before calling it stuck.
  for (int i = 0; i < 1000 && grabber->isRunning (); ++i)
    std::this_thread::sleep_for (std::chrono::milliseconds (10));
  EXPECT_FALSE (grabber->isRunning ());
  grabber->stop ();
  EXPECT_EQ (grabber->lastError (), "");
  std::lock_guard<std::mutex> lock (m);
  ASSERT_FALSE (frames.empty ());
  for (std::size_t k = 1; k < frames.size (); ++k)
    EXPECT_GT (frames[k], frames[k - 1]);
  EXPECT_LT (frames.back (), 7u);
  EXPECT_THROW (grabber->setFramesPerSecond (-1.f), ParameterError);
}

TEST (OpenThreeDRecorderFolders, AreReadWithTheirIntrinsicsFileNames)
{
  // Open3D's RealSense recorder writes color/, depth/ and camera_intrinsic.json; its Azure
  // Kinect recorder intrinsic.json; neither writes a trajectory or masks.
  const simulation::SyntheticSequence sequence = test::smallTabletop (3, 160, 120, true, 3);
  for (const char* name : {"camera_intrinsic.json", "intrinsic.json"})
  {
    test::TempDir dir;
    simulation::writeSyntheticSequence (sequence, io::DatasetLayout::Redwood, dir / "seq");
    boost::filesystem::rename (dir / "seq/image", dir / "seq/color");
    boost::filesystem::rename (dir / "seq/camera_intrinsics.json", dir / (std::string ("seq/") + name));
    for (const char* other : {"trajectory.log", "instance", "label"})
      boost::filesystem::remove_all (dir / (std::string ("seq/") + other));
    EXPECT_EQ (io::toString (io::detectSequenceFormat (dir / "seq")), "redwood") << name;
    const io::DatasetGrabber::Ptr grabber = io::openDataset (dir / "seq");
    ASSERT_EQ (grabber->size (), 3u) << name;
    EXPECT_FALSE (grabber->hasPoses ());
    EXPECT_NEAR (grabber->camera ().fx, sequence.camera ().fx, 1e-9) << name;
    EXPECT_NEAR (grabber->camera ().cy, sequence.camera ().cy, 1e-9) << name;
    const RGBDFrame::Ptr truth = sequence.frame (1), read = grabber->readFrame (1);
    EXPECT_EQ (cv::norm (read->color, truth->color, cv::NORM_INF), 0.0) << name;
    cv::Mat valid = truth->depth > 0;
    EXPECT_LT (cv::norm (read->depth, truth->depth, cv::NORM_INF, valid), 0.5e-3 + 1e-6) << name;

    // Without any intrinsics file: one line naming the file looked for.
    boost::filesystem::remove (dir / (std::string ("seq/") + name));
    try
    {
      io::openDataset (dir / "seq");
      ADD_FAILURE () << "no intrinsics, no error";
    }
    catch (const Error& e)
    {
      EXPECT_NE (std::string (e.what ()).find ("camera_intrinsics.json"), std::string::npos) << e.what ();
      EXPECT_NE (std::string (e.what ()).find ("camera_intrinsic.json"), std::string::npos) << e.what ();
    }
  }
}
