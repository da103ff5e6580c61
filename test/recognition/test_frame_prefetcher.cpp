// SPDX-License-Identifier: BSD-3-Clause
// FramePrefetcher: a recorded sequence read and masked ahead of the loop, frame-exact —
// every frame once, in order, with the masks of that very frame; errors in their place.
#include <cuefusion/common/exceptions.h>
#include <cuefusion/recognition/frame_prefetcher.h>

#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <thread>

using namespace cuefusion;

namespace
{
RGBDFrame::Ptr
frameNumber (std::size_t i)
{
  auto f = std::make_shared<RGBDFrame> ();
  f->index = i;
  f->depth = cv::Mat (4, 4, CV_32F, cv::Scalar (static_cast<float> (i)));
  f->color = cv::Mat::zeros (4, 4, CV_8UC3);
  return f;
}

/** One instance whose class_id is the frame's index read from its depth (so a mask set
  * computed on another frame shows); no masks on frames divisible by 3; throws on one. */
class IndexSource : public recognition::InstanceSegmenter
{
public:
  explicit IndexSource (std::size_t fail_at = 1000) : fail_at_ (fail_at) {}
  bool
  segment (const RGBDFrame& frame, std::vector<Instance>& instances) override
  {
    last_ = frame.index;
    if (frame.index == fail_at_)
      throw Error ("index source", "frame " + std::to_string (frame.index) + " cannot be segmented");
    if (frame.index % 3 == 0)
      return false;
    Instance instance;
    instance.class_id = static_cast<int> (frame.depth.at<float> (0, 0));
    instance.mask = cv::Mat::ones (frame.depth.size (), CV_8U);
    instances = {instance};
    return true;
  }
  std::string name () const override { return "index"; }
  /** Stages named by the frame's index, so the prefetcher must carry each frame's own. */
  recognition::SegmenterTimings
  lastTimings () const override
  {
    return {static_cast<double> (last_), 2.0 * static_cast<double> (last_), 0.5};
  }

private:
  std::size_t fail_at_;
  std::size_t last_ = 0;
};
}  // namespace

TEST (FramePrefetcher, EveryFrameOnceInOrderWithItsOwnMasks)
{
  const std::size_t n = 40;
  recognition::FramePrefetcher ahead (frameNumber, n, std::make_shared<IndexSource> ());
  for (std::size_t k = 0; k < n; ++k)
  {
    std::optional<recognition::PreparedFrame> p = ahead.next ();
    ASSERT_TRUE (p.has_value ()) << "frame " << k;
    ASSERT_EQ (p->frame->index, k);
    EXPECT_FALSE (p->mask_error);
    EXPECT_EQ (p->have_masks, k % 3 != 0) << "frame " << k;
    if (k % 3 != 0)
    {
      ASSERT_EQ (p->instances.size (), 1u);
      EXPECT_EQ (p->instances[0].class_id, static_cast<int> (k));
    }
    EXPECT_GE (p->read_ms, 0.0);
    EXPECT_GE (p->masks_ms, 0.0);
    EXPECT_EQ (p->masks_stages.input_ms, static_cast<double> (k));
    EXPECT_EQ (p->masks_stages.forward_ms, 2.0 * static_cast<double> (k));
  }
  EXPECT_FALSE (ahead.next ().has_value ());
  EXPECT_FALSE (ahead.next ().has_value ());
}

TEST (FramePrefetcher, WithoutAMaskSourceFramesComeWithoutMasks)
{
  recognition::FramePrefetcher ahead (frameNumber, 5, nullptr);
  for (std::size_t k = 0; k < 5; ++k)
  {
    std::optional<recognition::PreparedFrame> p = ahead.next ();
    ASSERT_TRUE (p.has_value ());
    EXPECT_EQ (p->frame->index, k);
    EXPECT_FALSE (p->have_masks);
    EXPECT_TRUE (p->instances.empty ());
    EXPECT_EQ (p->masks_ms, 0.0);
  }
  EXPECT_FALSE (ahead.next ().has_value ());
}

TEST (FramePrefetcher, ReadsAtMostTheQueueAheadOfTheCaller)
{
  // A caller slower than the reader: the reader never gets further ahead than the queue
  // allows (frame i is read only once frame i - queue_length was taken; the taker's count
  // is raised just after next() returns, hence one frame's slack).
  for (const std::size_t length : {std::size_t (1), std::size_t (3)})
  {
    std::atomic<std::size_t> taken{0}, worst_lead{0};
    const auto reader = [&] (std::size_t i) {
      const std::size_t lead = i - std::min (i, taken.load ());
      worst_lead = std::max (worst_lead.load (), lead);
      return frameNumber (i);
    };
    recognition::FramePrefetcherConfig config;
    config.queue_length = length;
    recognition::FramePrefetcher ahead (reader, 30, nullptr, config);
    while (std::optional<recognition::PreparedFrame> p = ahead.next ())
    {
      std::this_thread::sleep_for (std::chrono::milliseconds (1));  // the loop's work
      ++taken;
    }
    EXPECT_EQ (taken.load (), 30u);
    EXPECT_LE (worst_lead.load (), length + 1) << "queue_length " << length;
    EXPECT_GE (worst_lead.load (), length) << "the reader did not run ahead at all";
  }
}

TEST (FramePrefetcher, AReadErrorComesAfterTheFramesBeforeIt)
{
  const auto reader = [] (std::size_t i) {
    if (i == 3)
      throw Error ("/data/seq/depth/000003.png", "not a PNG image");
    return frameNumber (i);
  };
  recognition::FramePrefetcher ahead (reader, 10, std::make_shared<IndexSource> ());
  for (std::size_t k = 0; k < 3; ++k)
  {
    std::optional<recognition::PreparedFrame> p = ahead.next ();
    ASSERT_TRUE (p.has_value ());
    EXPECT_EQ (p->frame->index, k);
  }
  try
  {
    ahead.next ();
    FAIL () << "the unreadable frame was not reported";
  }
  catch (const Error& e)
  {
    EXPECT_NE (std::string (e.what ()).find ("000003.png"), std::string::npos) << e.what ();
  }
  EXPECT_FALSE (ahead.next ().has_value ());  // reported once; nothing after it
}

TEST (FramePrefetcher, AMaskErrorTravelsWithItsFrame)
{
  recognition::FramePrefetcher ahead (frameNumber, 6, std::make_shared<IndexSource> (4));
  for (std::size_t k = 0; k < 6; ++k)
  {
    std::optional<recognition::PreparedFrame> p = ahead.next ();
    ASSERT_TRUE (p.has_value ());
    EXPECT_EQ (p->frame->index, k);
    EXPECT_EQ (static_cast<bool> (p->mask_error), k == 4) << "frame " << k;
    if (k == 4)
    {
      EXPECT_THROW (std::rethrow_exception (p->mask_error), Error);
    }
  }
}

TEST (FramePrefetcher, StopEndsTheSequenceEarly)
{
  std::atomic<std::size_t> reads{0};
  recognition::FramePrefetcher ahead ([&] (std::size_t i) { ++reads; return frameNumber (i); }, 1000, nullptr);
  ASSERT_TRUE (ahead.next ().has_value ());
  ahead.stop ();
  EXPECT_FALSE (ahead.next ().has_value ());
  EXPECT_LE (reads.load (), 1 + ahead.getConfig ().queue_length + 1);
}

TEST (FramePrefetcher, RefusesAnEmptyQueue)
{
  recognition::FramePrefetcherConfig config;
  config.queue_length = 0;
  try
  {
    recognition::FramePrefetcher ahead (frameNumber, 3, nullptr, config);
    FAIL () << "queue_length 0 was accepted";
  }
  catch (const ParameterError& e)
  {
    EXPECT_NE (std::string (e.what ()).find ("queue_length"), std::string::npos) << e.what ();
  }
}
