// SPDX-License-Identifier: BSD-3-Clause
#include <cuefusion/common/exceptions.h>
#include <cuefusion/recognition/asynchronous_segmenter.h>

namespace cuefusion
{
namespace recognition
{
AsynchronousSegmenter::AsynchronousSegmenter (InstanceSegmenter::Ptr inner) : inner_ (std::move (inner))
{
  if (!inner_)
    throw ParameterError ("AsynchronousSegmenter", "needs a mask source");
  worker_ = std::thread ([this] { work (); });
}

AsynchronousSegmenter::~AsynchronousSegmenter ()
{
  {
    const std::lock_guard<std::mutex> lock (mutex_);
    stop_ = true;
  }
  wake_.notify_all ();
  worker_.join ();
}

bool
AsynchronousSegmenter::segment (const RGBDFrame& frame, std::vector<Instance>& instances)
{
  // A copy with its own colour and depth images (what networks read): a live grabber may
  // reuse its buffers once the frame is handed on. Made outside the lock.
  auto copy = std::make_shared<RGBDFrame> (frame);
  copy->color = frame.color.clone ();
  copy->depth = frame.depth.clone ();
  std::unique_lock<std::mutex> lock (mutex_);
  if (error_)
  {
    const std::exception_ptr error = error_;
    error_ = nullptr;
    std::rethrow_exception (error);
  }
  pending_ = std::move (copy);
  lock.unlock ();
  wake_.notify_one ();
  lock.lock ();
  if (!have_result_)
    return false;
  returned_frame_ = result_frame_;
  instances = result_;
  return result_ok_;
}

std::string
AsynchronousSegmenter::name () const
{
  return "async:" + inner_->name ();
}

std::optional<std::size_t>
AsynchronousSegmenter::lastResultFrame () const
{
  const std::lock_guard<std::mutex> lock (mutex_);
  return returned_frame_;
}

std::size_t
AsynchronousSegmenter::framesSegmented () const
{
  const std::lock_guard<std::mutex> lock (mutex_);
  return segmented_;
}

void
AsynchronousSegmenter::waitIdle ()
{
  std::unique_lock<std::mutex> lock (mutex_);
  idle_.wait (lock, [this] { return !pending_ && !running_job_; });
}

void
AsynchronousSegmenter::work ()
{
  std::unique_lock<std::mutex> lock (mutex_);
  for (;;)
  {
    wake_.wait (lock, [this] { return stop_ || pending_; });
    if (stop_)
      return;
    const std::shared_ptr<const RGBDFrame> frame = std::move (pending_);
    pending_.reset ();
    running_job_ = true;
    lock.unlock ();
    std::vector<Instance> instances;
    bool ok = false;
    std::exception_ptr error;
    try
    {
      ok = inner_->segment (*frame, instances);
    }
    catch (...)
    {
      error = std::current_exception ();
    }
    lock.lock ();
    running_job_ = false;
    ++segmented_;
    if (error)
      error_ = error;
    else
    {
      have_result_ = true;
      result_ok_ = ok;
      result_ = std::move (instances);
      result_frame_ = frame->index;
    }
    if (!pending_)
      idle_.notify_all ();
  }
}
}  // namespace recognition
}  // namespace cuefusion
