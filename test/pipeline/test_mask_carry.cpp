// SPDX-License-Identifier: BSD-3-Clause
// carryMasks: an earlier frame's masks moved into the current frame by the camera's motion,
// checked on two analytic views (a square board 0.5 m in front of a wall) with exact depth.
#include <cuefusion/common/exceptions.h>
#include <cuefusion/pipeline/mask_carry.h>

#include <gtest/gtest.h>

#include <random>

using namespace cuefusion;

namespace
{
constexpr float kWall = 2.0f, kBoard = 1.5f, kHalfSide = 0.2f;

PinholeCamera
camera ()
{
  PinholeCamera c;
  c.width = 320;
  c.height = 240;
  c.fx = c.fy = 262.5;
  c.cx = 159.5;
  c.cy = 119.5;
  return c;
}

/** The view from a camera at \a t looking along world z: its depth and which pixels see
  * the board (1), the wall (2). */
pipeline::MaskView
render (const Eigen::Vector3d& t, cv::Mat& truth)
{
  pipeline::MaskView view;
  view.camera = camera ();
  view.pose = Eigen::Translation3d (t) * Eigen::Isometry3d::Identity ();
  view.depth = cv::Mat (view.camera.height, view.camera.width, CV_32F);
  truth = cv::Mat (view.depth.size (), CV_8U);
  for (int v = 0; v < view.depth.rows; ++v)
    for (int u = 0; u < view.depth.cols; ++u)
    {
      const Eigen::Vector3f ray = view.camera.backProject (static_cast<float> (u), static_cast<float> (v), 1.f);
      const float d = kBoard - static_cast<float> (t.z ());
      const float x = static_cast<float> (t.x ()) + d * ray.x (), y = static_cast<float> (t.y ()) + d * ray.y ();
      const bool board = std::abs (x) < kHalfSide && std::abs (y) < kHalfSide;
      view.depth.at<float> (v, u) = board ? d : kWall - static_cast<float> (t.z ());
      truth.at<std::uint8_t> (v, u) = board ? 1 : 2;
    }
  return view;
}

double
iou (const cv::Mat& a, const cv::Mat& b)
{
  return static_cast<double> (cv::countNonZero (a & b)) / std::max (1, cv::countNonZero (a | b));
}
}  // namespace

TEST (MaskCarry, MasksOfAnEarlierViewLandWhereTheCurrentViewSeesTheirObjects)
{
  std::mt19937 rng (std::random_device{} ());
  std::uniform_real_distribution<double> shift (0.06, 0.12), sign (-1.0, 1.0);
  for (int round = 0; round < 3; ++round)
  {
    // The camera moves sideways by 6–12 cm (the board moves 21–42 px) and a little in depth.
    const Eigen::Vector3d motion (shift (rng) * (sign (rng) < 0 ? -1 : 1), shift (rng) * (sign (rng) < 0 ? -1 : 1), 0.05 * sign (rng));
    SCOPED_TRACE ("motion " + std::to_string (motion.x ()) + " " + std::to_string (motion.y ()) + " " + std::to_string (motion.z ()));
    cv::Mat truth_from, truth_to;
    const pipeline::MaskView from = render (Eigen::Vector3d::Zero (), truth_from);
    const pipeline::MaskView to = render (motion, truth_to);
    Instance board, wall;
    board.class_id = 3;
    board.score = 0.9f;
    board.mask = truth_from == 1;
    wall.class_id = 4;
    wall.score = 0.5f;
    wall.mask = truth_from == 2;
    const cv::Mat board_given = board.mask.clone ();
    const std::vector<Instance> carried = pipeline::carryMasks ({board, wall}, from, to);
    ASSERT_EQ (carried.size (), 2u);
    EXPECT_EQ (cv::countNonZero (board.mask != board_given), 0);  // the masks given are left as they were
    EXPECT_EQ (carried[0].class_id, 3);
    EXPECT_FLOAT_EQ (carried[0].score, 0.9f);
    // Where the current view sees the board (to the pixel along its border)...
    EXPECT_GT (iou (carried[0].mask, truth_to == 1), 0.95);
    EXPECT_LT (iou (board.mask, truth_to == 1), 0.85);  // the motion did move it
    // ... and the wall, less what the board hid from the earlier view (no mask there) and
    // what lay outside it.
    cv::Mat hidden_before (truth_to.size (), CV_8U, cv::Scalar (0)), wall_seen_before = hidden_before.clone ();
    for (int v = 0; v < truth_to.rows; ++v)
      for (int u = 0; u < truth_to.cols; ++u)
      {
        if (truth_to.at<std::uint8_t> (v, u) != 2)
          continue;
        const Eigen::Vector3f p = (from.pose.inverse () * to.pose).cast<float> () *
                                  to.camera.backProject (static_cast<float> (u), static_cast<float> (v), to.depth.at<float> (v, u));
        int us, vs;
        if (from.camera.projectToPixel (p, us, vs))
          (truth_from.at<std::uint8_t> (vs, us) == 1 ? hidden_before : wall_seen_before).at<std::uint8_t> (v, u) = 255;
      }
    ASSERT_GT (cv::countNonZero (hidden_before), 200);
    EXPECT_LT (cv::countNonZero (carried[1].mask & hidden_before), cv::countNonZero (hidden_before) / 50);
    EXPECT_LT (cv::countNonZero (carried[0].mask & hidden_before), cv::countNonZero (hidden_before) / 50);
    EXPECT_GT (iou (carried[1].mask, wall_seen_before), 0.98);
  }
}

TEST (MaskCarry, InstancesLeftWithoutAPixelAreDroppedAndBadDepthIsRefused)
{
  cv::Mat truth;
  const pipeline::MaskView from = render (Eigen::Vector3d::Zero (), truth);
  // Moved so far that the board leaves the view.
  cv::Mat far_truth;
  const pipeline::MaskView to = render (Eigen::Vector3d (3.0, 0.0, 0.0), far_truth);
  Instance board;
  board.mask = truth == 1;
  EXPECT_TRUE (pipeline::carryMasks ({board}, from, to).empty ());
  EXPECT_TRUE (pipeline::carryMasks ({}, from, to).empty ());
  pipeline::MaskView bad = to;
  bad.depth = cv::Mat (to.depth.size (), CV_16U, cv::Scalar (1000));
  EXPECT_THROW (pipeline::carryMasks ({board}, from, bad), Error);
}
