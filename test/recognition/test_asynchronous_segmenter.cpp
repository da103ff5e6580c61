// SPDX-License-Identifier: BSD-3-Clause
// AsynchronousSegmenter: segmentation never waits for the mask source, which always runs
// on the newest frame. A gated fake source makes the timing explicit without clocks.
#include <cuefusion/common/exceptions.h>
#include <cuefusion/recognition/asynchronous_segmenter.h>

#include <gtest/gtest.h>

#include <condition_variable>
#include <mutex>

using namespace cuefusion;

namespace
{
/** Reports one instance whose class_id is the frame index; each run waits for a permit. */
class GatedSource : public recognition::InstanceSegmenter
{
public:
  bool
  segment (const RGBDFrame& frame, std::vector<Instance>& instances) override
  {
    std::unique_lock<std::mutex> lock (mutex_);
    started_.push_back (frame.index);
    changed_.notify_all ();
    changed_.wait (lock, [this] { return permits_ > 0; });
    --permits_;
    if (frame.index == fail_at_)
      throw Error ("gated source", "frame " + std::to_string (frame.index) + " is unreadable");
    Instance instance;
    instance.class_id = static_cast<int> (frame.index);
    instance.mask = cv::Mat::zeros (frame.depth.size (), CV_8U);
    instances = {instance};
    return true;
  }
  std::string name () const override { return "gated"; }

  void
  permit ()
  {
    const std::lock_guard<std::mutex> lock (mutex_);
    ++permits_;
    changed_.notify_all ();
  }
  /** Blocks until the source has started on \a n frames. */
  void
  waitStarted (std::size_t n)
  {
    std::unique_lock<std::mutex> lock (mutex_);
    changed_.wait (lock, [&] { return started_.size () >= n; });
  }
  std::vector<std::size_t>
  started ()
  {
    const std::lock_guard<std::mutex> lock (mutex_);
    return started_;
  }
  std::size_t fail_at_ = 1000;

private:
  std::mutex mutex_;
  std::condition_variable changed_;
  int permits_ = 0;
  std::vector<std::size_t> started_;
};

RGBDFrame
frameNumber (std::size_t i)
{
  RGBDFrame f;
  f.index = i;
  f.depth = cv::Mat::zeros (4, 4, CV_32F);
  f.color = cv::Mat::zeros (4, 4, CV_8UC3);
  return f;
}
}  // namespace

TEST (AsynchronousSegmenter, NeverWaitsAndRunsTheNewestFrame)
{
  auto source = std::make_shared<GatedSource> ();
  recognition::AsynchronousSegmenter async (source);
  std::vector<Instance> instances;
  // The source is blocked on frame 0: the call still returns, with nothing yet.
  EXPECT_FALSE (async.segment (frameNumber (0), instances));
  source->waitStarted (1);
  // Frames 1, 2, 3 arrive while 0 is running: only the newest (3) waits; 1 and 2 are dropped.
  for (std::size_t i = 1; i <= 3; ++i)
    EXPECT_FALSE (async.segment (frameNumber (i), instances)) << i;
  source->permit ();          // 0 finishes
  source->waitStarted (2);    // the worker took the newest waiting frame
  EXPECT_EQ (source->started (), (std::vector<std::size_t>{0, 3}));
  // Frame 4 gets frame 0's masks, the newest finished.
  ASSERT_TRUE (async.segment (frameNumber (4), instances));
  ASSERT_EQ (instances.size (), 1u);
  EXPECT_EQ (instances[0].class_id, 0);
  EXPECT_EQ (async.lastResultFrame (), std::optional<std::size_t> (0));
  source->permit ();          // 3 finishes, then 4 (queued above) runs
  source->permit ();
  async.waitIdle ();
  EXPECT_EQ (source->started (), (std::vector<std::size_t>{0, 3, 4}));
  ASSERT_TRUE (async.segment (frameNumber (5), instances));
  EXPECT_EQ (instances[0].class_id, 4);
  source->permit ();
  async.waitIdle ();
  EXPECT_EQ (async.framesSegmented (), 4u);
  EXPECT_EQ (async.name (), "async:gated");
}

TEST (AsynchronousSegmenter, AnErrorOfTheSourceReachesTheCaller)
{
  auto source = std::make_shared<GatedSource> ();
  source->fail_at_ = 0;
  recognition::AsynchronousSegmenter async (source);
  std::vector<Instance> instances;
  EXPECT_FALSE (async.segment (frameNumber (0), instances));
  source->permit ();
  source->waitStarted (1);
  async.waitIdle ();
  EXPECT_THROW (async.segment (frameNumber (1), instances), Error);  // reported once…
  EXPECT_FALSE (async.segment (frameNumber (2), instances));          // …then it goes on
  source->permit ();
  source->waitStarted (2);
  async.waitIdle ();
  EXPECT_TRUE (async.segment (frameNumber (3), instances));
  EXPECT_EQ (instances[0].class_id, 2);
  source->permit ();
  async.waitIdle ();
  EXPECT_THROW (recognition::AsynchronousSegmenter (nullptr), ParameterError);
}
