// SPDX-License-Identifier: BSD-3-Clause
// PeriodicSegmenter: the mask source on every N-th frame, the masks of the last frame it
// ran on for the frames between (thesis §6.1 on a fixed schedule).
#include <cuefusion/common/exceptions.h>
#include <cuefusion/recognition/periodic_segmenter.h>

#include <gtest/gtest.h>

#include <random>
#include <set>

using namespace cuefusion;

namespace
{
/** One instance whose class_id is the frame index it was computed on; nothing (false)
  * for the frames listed in \a empty. Records the frames it ran on. */
class IndexSource : public recognition::InstanceSegmenter
{
public:
  bool
  segment (const RGBDFrame& frame, std::vector<Instance>& instances) override
  {
    ran.push_back (frame.index);
    instances.clear ();
    if (empty.count (frame.index))
      return false;
    Instance instance;
    instance.class_id = static_cast<int> (frame.index);
    instance.mask = cv::Mat (4, 4, CV_8U, cv::Scalar (static_cast<int> (frame.index % 200) + 1));
    instances.push_back (instance);
    return true;
  }
  std::string name () const override { return "index"; }
  SegmenterTimings lastTimings () const override { return {1.0, 2.0, 3.0}; }

  std::vector<std::size_t> ran;
  std::set<std::size_t> empty;
};

RGBDFrame
frameAt (std::size_t index)
{
  RGBDFrame frame;
  frame.index = index;
  frame.depth = cv::Mat (4, 4, CV_32F, cv::Scalar (1.f));
  return frame;
}
}  // namespace

TEST (PeriodicSegmenter, RunsTheSourceOnEveryNthFrameAndHandsTheFramesBetweenItsLastMasks)
{
  // A period and a run length drawn at random; frames in order from a random first index.
  std::mt19937 rng (std::random_device{} ());
  const std::size_t period = std::uniform_int_distribution<std::size_t> (2, 9) (rng);
  const std::size_t first = std::uniform_int_distribution<std::size_t> (0, 50) (rng);
  const std::size_t frames = std::uniform_int_distribution<std::size_t> (3 * period, 60) (rng);
  SCOPED_TRACE ("period " + std::to_string (period) + ", frames " + std::to_string (first) + "+" + std::to_string (frames));
  auto source = std::make_shared<IndexSource> ();
  recognition::PeriodicSegmenter periodic (source, period);
  EXPECT_EQ (periodic.name (), "index");
  EXPECT_FALSE (periodic.lastResultFrame ().has_value ());
  for (std::size_t i = first; i < first + frames; ++i)
  {
    std::vector<Instance> instances;
    ASSERT_TRUE (periodic.segment (frameAt (i), instances));
    const std::size_t computed_on = first + (i - first) / period * period;
    ASSERT_EQ (instances.size (), 1u);
    EXPECT_EQ (instances[0].class_id, static_cast<int> (computed_on)) << "frame " << i;
    EXPECT_EQ (cv::countNonZero (instances[0].mask != static_cast<int> (computed_on % 200) + 1), 0);
    EXPECT_EQ (periodic.lastResultFrame (), computed_on);
    // The stages are the source's where it ran, zero where its masks were reused.
    EXPECT_EQ (periodic.lastTimings ().forward_ms, i == computed_on ? 2.0 : 0.0);
  }
  std::vector<std::size_t> expected;
  for (std::size_t i = first; i < first + frames; i += period)
    expected.push_back (i);
  EXPECT_EQ (source->ran, expected);
  EXPECT_EQ (periodic.framesSegmented (), expected.size ());
}

TEST (PeriodicSegmenter, FollowsSkippedIndicesStartsAgainAndPassesOnFramesWithoutMasks)
{
  auto source = std::make_shared<IndexSource> ();
  source->empty = {7};
  recognition::PeriodicSegmenter periodic (source, 3);
  // A live grabber skips indices: the source runs on the first frame at least 3 after its
  // last. Frame 7 has no masks: the frames that reuse its result have none either.
  const std::vector<std::size_t> indices{0, 1, 4, 5, 6, 7, 8, 9, 10, 11};
  const std::vector<bool> have{true, true, true, true, true, false, false, false, true, true};
  for (std::size_t k = 0; k < indices.size (); ++k)
  {
    std::vector<Instance> instances (2);  // replaced, never appended to
    EXPECT_EQ (periodic.segment (frameAt (indices[k]), instances), have[k]) << "frame " << indices[k];
    EXPECT_EQ (instances.size (), have[k] ? 1u : 0u);
  }
  EXPECT_EQ (source->ran, (std::vector<std::size_t>{0, 4, 7, 10}));
  // An index before the last run's (a new sequence through the same source): it runs.
  std::vector<Instance> instances;
  EXPECT_TRUE (periodic.segment (frameAt (2), instances));
  EXPECT_EQ (source->ran.back (), 2u);
  EXPECT_EQ (instances[0].class_id, 2);

  // Period 1 is every frame.
  auto every = std::make_shared<IndexSource> ();
  recognition::PeriodicSegmenter each (every, 1);
  for (std::size_t i = 0; i < 5; ++i)
    each.segment (frameAt (i), instances);
  EXPECT_EQ (every->ran, (std::vector<std::size_t>{0, 1, 2, 3, 4}));
}

TEST (PeriodicSegmenter, RefusesAPeriodOutOfRangeNamingTheField)
{
  auto source = std::make_shared<IndexSource> ();
  for (const std::size_t period : {std::size_t{0}, recognition::PeriodicSegmenter::kMaxPeriod + 1})
  {
    try
    {
      recognition::PeriodicSegmenter periodic (source, period);
      ADD_FAILURE () << "period " << period << " accepted";
    }
    catch (const ParameterError& e)
    {
      EXPECT_NE (std::string (e.what ()).find ("PeriodicSegmenter::period"), std::string::npos) << e.what ();
    }
  }
  EXPECT_THROW (recognition::PeriodicSegmenter (nullptr, 2), ParameterError);
  EXPECT_NO_THROW (recognition::PeriodicSegmenter (source, recognition::PeriodicSegmenter::kMaxPeriod));
}
