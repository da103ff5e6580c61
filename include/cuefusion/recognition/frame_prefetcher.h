// SPDX-License-Identifier: BSD-3-Clause
#pragma once

#include <cuefusion/recognition/instance_segmenter.h>

#include <condition_variable>
#include <cstddef>
#include <deque>
#include <exception>
#include <functional>
#include <mutex>
#include <optional>
#include <thread>

namespace cuefusion
{
namespace recognition
{
/** \brief A frame of a recorded sequence, read and given its masks ahead of the loop. */
struct PreparedFrame
{
  RGBDFrame::Ptr frame;
  bool have_masks = false;          ///< the mask source's answer for this frame
  std::vector<Instance> instances;  ///< its masks when it had some
  std::exception_ptr mask_error;    ///< what the mask source threw on this frame, if it did
  double read_ms = 0.0;             ///< reading and decoding the frame's files
  double masks_ms = 0.0;            ///< the mask source (the network) on it
  SegmenterTimings masks_stages;    ///< its stages (InstanceSegmenter::lastTimings)
  std::optional<std::size_t> masks_frame;  ///< the frame its masks were computed on (InstanceSegmenter::lastResultFrame)
};

struct FramePrefetcherConfig
{
  /** Frames read and masked ahead of the one the caller takes, at most; each holds a
    * frame's images and masks (about 3 MB at 640×480). */
  std::size_t queue_length = 2;

  /** \brief Throws ParameterError naming the field when a value is out of range. */
  void validate () const;
};

/** \brief Reads a recorded sequence's frames and runs the mask source on each on its own
  * thread, in order, while the caller processes earlier frames: reading, decoding and the
  * network overlap the loop instead of adding to it.
  *
  * Frame-exact: the caller receives every frame once, in order, with the masks computed
  * on that very frame (the masks of a frame do not depend on the map), so a run is the
  * same as reading and masking each frame in the loop. Contrast AsynchronousSegmenter,
  * which hands a live camera's frames the newest masks finished on an earlier frame.
  *
  * Errors keep their place: a frame that cannot be read ends the sequence there (next()
  * rethrows the reader's error after every earlier frame was delivered); an error of the
  * mask source travels with its frame (PreparedFrame::mask_error).
  */
class FramePrefetcher
{
public:
  /** Reads frame i of the sequence (0-based); throws cuefusion::Error naming the file. */
  using FrameReader = std::function<RGBDFrame::Ptr (std::size_t)>;

  /** \brief Starts reading frames 0 … \a frames − 1; \a masks may be null (no masks). */
  FramePrefetcher (FrameReader read, std::size_t frames, InstanceSegmenter::Ptr masks,
                   const FramePrefetcherConfig& config = FramePrefetcherConfig ());
  ~FramePrefetcher ();
  FramePrefetcher (const FramePrefetcher&) = delete;
  FramePrefetcher& operator= (const FramePrefetcher&) = delete;

  /** \brief The next frame in order, waiting for it if the worker is behind; nullopt
    * after the last frame or once stop() was called. Rethrows a read error at its frame. */
  std::optional<PreparedFrame> next ();

  /** \brief Stops reading ahead (a signal, an error of the caller); next() then gives
    * nullopt. Blocks until the frame being read or masked is done. */
  void stop ();

  const FramePrefetcherConfig& getConfig () const { return config_; }

private:
  void work ();

  FrameReader read_;
  std::size_t frames_;
  InstanceSegmenter::Ptr masks_;
  FramePrefetcherConfig config_;
  std::mutex mutex_;
  std::condition_variable ready_, room_;
  std::deque<PreparedFrame> queue_;
  std::exception_ptr read_error_;  ///< after the frames in queue_
  bool finished_ = false;          ///< the worker produced its last frame (or failed)
  bool stop_ = false;
  std::thread worker_;
};
}  // namespace recognition
}  // namespace cuefusion
