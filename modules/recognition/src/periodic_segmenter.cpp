// SPDX-License-Identifier: BSD-3-Clause
#include <cuefusion/common/exceptions.h>
#include <cuefusion/recognition/periodic_segmenter.h>

#include <string>

namespace cuefusion
{
namespace recognition
{
PeriodicSegmenter::PeriodicSegmenter (InstanceSegmenter::Ptr inner, std::size_t period)
  : inner_ (std::move (inner)), period_ (period)
{
  if (!inner_)
    throw ParameterError ("PeriodicSegmenter", "needs a mask source");
  checkPeriod (period_ > kMaxPeriod ? static_cast<long long> (kMaxPeriod) + 1 : static_cast<long long> (period_));
}

void
PeriodicSegmenter::checkPeriod (long long period)
{
  if (period < 1 || period > static_cast<long long> (kMaxPeriod))
    throw ParameterError ("PeriodicSegmenter::period",
                          "must lie in [1, " + std::to_string (kMaxPeriod) + "] frames, got " + std::to_string (period));
}

bool
PeriodicSegmenter::segment (const RGBDFrame& frame, std::vector<Instance>& instances)
{
  const bool due = !last_run_ || frame.index < *last_run_ || frame.index - *last_run_ >= period_;
  ran_now_ = due;
  if (due)
  {
    last_.clear ();
    last_ok_ = inner_->segment (frame, last_);
    last_run_ = frame.index;
    ++runs_;
  }
  // The masks are read, never written, downstream (the instance merge divides them into
  // new ones): the frames between share the images.
  instances = last_;
  return last_ok_;
}

std::string
PeriodicSegmenter::name () const
{
  return inner_->name ();
}

SegmenterTimings
PeriodicSegmenter::lastTimings () const
{
  return ran_now_ ? inner_->lastTimings () : SegmenterTimings ();
}
}  // namespace recognition
}  // namespace cuefusion
