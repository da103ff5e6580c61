// SPDX-License-Identifier: BSD-3-Clause
#pragma once

#include <cuefusion/recognition/instance_segmenter.h>

#include <cstddef>
#include <optional>
#include <string>
#include <vector>

namespace cuefusion
{
namespace recognition
{
/** \brief Runs another InstanceSegmenter on every \a period-th frame only and hands the
  * frames between the masks of the last frame it ran on (thesis §6.1: the geometric
  * segmentation on every frame, the network "only when possible").
  *
  * This is what a live camera gets from AsynchronousSegmenter — masks computed on an
  * earlier frame (lastResultFrame says which; FusionPipeline carries them into the current
  * frame by the camera's motion) — on a fixed schedule instead of the
  * network's speed, so a recorded run costs a period-th of the network's work and still
  * repeats byte for byte (and reading ahead, FramePrefetcher, gives the same outputs as
  * --sequential). The schedule follows the frames' indices: the source runs on the first
  * frame it is given, then on the first frame at least \a period indices later (a live
  * grabber may skip indices); a frame whose index lies before the last run's starts
  * again.
  */
class PeriodicSegmenter : public InstanceSegmenter
{
public:
  /** Throws ParameterError ("PeriodicSegmenter::period") outside [1, kMaxPeriod] and
    * without a source. */
  PeriodicSegmenter (InstanceSegmenter::Ptr inner, std::size_t period);

  /** \brief The inner source's masks for \a frame when it is due; else the masks of the
    * last frame it ran on (what it returned then, true or false). */
  bool segment (const RGBDFrame& frame, std::vector<Instance>& instances) override;
  std::string name () const override;
  /** The inner source's stages when it ran on the last frame, zeros when the masks were reused. */
  SegmenterTimings lastTimings () const override;

  std::size_t getPeriod () const { return period_; }
  /** \brief Index of the frame the masks last returned were computed on (none before the first call). */
  std::optional<std::size_t> lastResultFrame () const override { return last_run_; }
  /** \brief Frames the inner source has run on so far. */
  std::size_t framesSegmented () const { return runs_; }

  static constexpr std::size_t kMaxPeriod = 1000;
  /** \brief Throws ParameterError ("PeriodicSegmenter::period") unless \a period lies in
    * [1, kMaxPeriod] (signed: what a user typed, before it is a size). */
  static void checkPeriod (long long period);

private:
  InstanceSegmenter::Ptr inner_;
  std::size_t period_;
  std::optional<std::size_t> last_run_;
  bool last_ok_ = false;
  bool ran_now_ = false;
  std::size_t runs_ = 0;
  std::vector<Instance> last_;
};
}  // namespace recognition
}  // namespace cuefusion
