// SPDX-License-Identifier: BSD-3-Clause
#pragma once

#include <cuefusion/recognition/instance_segmenter.h>

#include <condition_variable>
#include <cstddef>
#include <exception>
#include <mutex>
#include <optional>
#include <thread>

namespace cuefusion
{
namespace recognition
{
/** \brief Runs another InstanceSegmenter on its own thread, so segmentation never waits
  * for the network (thesis §6.1): each frame is handed to the worker — replacing a frame
  * still waiting there, since only the newest is worth running — and the call returns at
  * once with the newest masks the worker has finished, computed on an earlier frame
  * (lastResultFrame says which; FusionPipeline carries them into the current frame by the
  * camera's motion, carryMasks).
  *
  * Used for live cameras. Offline sequences keep the synchronous source, so a run is the
  * same every time.
  */
class AsynchronousSegmenter : public InstanceSegmenter
{
public:
  explicit AsynchronousSegmenter (InstanceSegmenter::Ptr inner);
  ~AsynchronousSegmenter () override;
  AsynchronousSegmenter (const AsynchronousSegmenter&) = delete;
  AsynchronousSegmenter& operator= (const AsynchronousSegmenter&) = delete;

  /** \brief Queues \a frame and returns the newest finished masks: true with them, false
    * while none has finished yet or the last finished frame had none. An error the inner
    * source threw is rethrown here (once). */
  bool segment (const RGBDFrame& frame, std::vector<Instance>& instances) override;
  std::string name () const override;

  /** \brief Index of the frame the masks last returned were computed on. */
  std::optional<std::size_t> lastResultFrame () const override;
  /** \brief Frames the inner source has run on so far. */
  std::size_t framesSegmented () const;
  /** \brief Blocks until no frame is waiting or running (tests, end of a run). */
  void waitIdle ();

private:
  void work ();

  InstanceSegmenter::Ptr inner_;
  mutable std::mutex mutex_;
  std::condition_variable wake_, idle_;
  std::shared_ptr<const RGBDFrame> pending_;
  bool running_job_ = false;
  bool stop_ = false;
  bool have_result_ = false;
  bool result_ok_ = false;
  std::vector<Instance> result_;
  std::size_t result_frame_ = 0;
  std::optional<std::size_t> returned_frame_;
  std::size_t segmented_ = 0;
  std::exception_ptr error_;
  std::thread worker_;
};
}  // namespace recognition
}  // namespace cuefusion
