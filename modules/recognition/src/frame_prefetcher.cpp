// SPDX-License-Identifier: BSD-3-Clause
#include <cuefusion/common/exceptions.h>
#include <cuefusion/recognition/frame_prefetcher.h>

#include <chrono>

namespace cuefusion
{
namespace recognition
{
namespace
{
double
millisecondsSince (std::chrono::steady_clock::time_point t0)
{
  return std::chrono::duration<double, std::milli> (std::chrono::steady_clock::now () - t0).count ();
}
}  // namespace

void
FramePrefetcherConfig::validate () const
{
  if (queue_length < 1)
    throw ParameterError ("FramePrefetcherConfig::queue_length", "must be at least 1, got 0");
}

FramePrefetcher::FramePrefetcher (FrameReader read, std::size_t frames, InstanceSegmenter::Ptr masks,
                                  const FramePrefetcherConfig& config)
  : read_ (std::move (read)), frames_ (frames), masks_ (std::move (masks)), config_ (config)
{
  config_.validate ();
  if (!read_)
    throw ParameterError ("FramePrefetcher", "needs a frame reader");
  worker_ = std::thread ([this] { work (); });
}

FramePrefetcher::~FramePrefetcher ()
{
  stop ();
}

void
FramePrefetcher::stop ()
{
  {
    const std::lock_guard<std::mutex> lock (mutex_);
    stop_ = true;
  }
  room_.notify_all ();
  ready_.notify_all ();
  if (worker_.joinable () && worker_.get_id () != std::this_thread::get_id ())
    worker_.join ();
}

std::optional<PreparedFrame>
FramePrefetcher::next ()
{
  std::unique_lock<std::mutex> lock (mutex_);
  ready_.wait (lock, [this] { return stop_ || !queue_.empty () || finished_; });
  if (stop_)
    return std::nullopt;
  if (queue_.empty ())
  {
    if (read_error_)
    {
      const std::exception_ptr error = read_error_;
      read_error_ = nullptr;  // once
      std::rethrow_exception (error);
    }
    return std::nullopt;
  }
  PreparedFrame prepared = std::move (queue_.front ());
  queue_.pop_front ();
  lock.unlock ();
  room_.notify_one ();
  return prepared;
}

void
FramePrefetcher::work ()
{
  for (std::size_t i = 0; i < frames_; ++i)
  {
    {
      std::unique_lock<std::mutex> lock (mutex_);
      room_.wait (lock, [this] { return stop_ || queue_.size () < config_.queue_length; });
      if (stop_)
        break;
    }
    PreparedFrame prepared;
    try
    {
      const auto t0 = std::chrono::steady_clock::now ();
      prepared.frame = read_ (i);
      prepared.read_ms = millisecondsSince (t0);
    }
    catch (...)
    {
      const std::lock_guard<std::mutex> lock (mutex_);
      read_error_ = std::current_exception ();
      break;
    }
    if (masks_)
    {
      const auto t0 = std::chrono::steady_clock::now ();
      try
      {
        prepared.have_masks = masks_->segment (*prepared.frame, prepared.instances);
        prepared.masks_stages = masks_->lastTimings ();
        prepared.masks_frame = masks_->lastResultFrame ();
      }
      catch (...)
      {
        prepared.mask_error = std::current_exception ();
      }
      prepared.masks_ms = millisecondsSince (t0);
    }
    {
      const std::lock_guard<std::mutex> lock (mutex_);
      queue_.push_back (std::move (prepared));
    }
    ready_.notify_one ();
  }
  {
    const std::lock_guard<std::mutex> lock (mutex_);
    finished_ = true;
  }
  ready_.notify_all ();
}
}  // namespace recognition
}  // namespace cuefusion
