// SPDX-License-Identifier: BSD-3-Clause
#pragma once

#include <cuefusion/io/rgbd_grabber.h>

#include <atomic>
#include <cstddef>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <vector>

namespace cuefusion
{
namespace io
{
/** \brief Files that make up one frame of an offline sequence. */
struct FrameRecord
{
  double timestamp = 0.0;
  std::string name;                        ///< stem used for output names
  std::string color_path;
  std::string depth_path;
  std::optional<Eigen::Isometry3d> pose;   ///< poses a layout keeps in one file (TUM, Redwood)
  std::string pose_path;                   ///< or one file per frame, read with the frame
  std::string pose_source;                 ///< the file the pose comes from (either kind), for messages
  std::string instance_path;               ///< optional CV_16U instance ids
  std::string class_path;                  ///< optional CV_16U class ids
};

/** \brief A recorded sequence in a dataset folder, read frame by frame.
  *
  * Two ways to run it:
  * - trigger mode (frames per second = 0, the default): start(), then every trigger()
  *   reads the next frame and emits it before returning — every frame exactly once, in
  *   order, for deterministic offline processing;
  * - real-time mode (setFramesPerSecond(fps > 0)): start() launches a thread that
  *   plays the sequence at fps like a live camera, skipping frames a slow consumer
  *   could not take in time.
  *
  * readFrame(i) gives random access for tools and tests. Subclasses only index the
  * folder (fill records_ and the cameras) and call finishSetup().
  */
class DatasetGrabber : public RGBDGrabber
{
public:
  using Ptr = std::shared_ptr<DatasetGrabber>;

  ~DatasetGrabber () override;

  /** \brief Number of frames (after setFrameLimit). */
  std::size_t size () const;
  /** \brief Depth intrinsics; colour is registered to them. */
  const PinholeCamera& camera () const { return camera_; }
  const std::string& root () const { return root_; }
  bool hasPoses () const;
  bool hasInstanceMasks () const;
  const std::vector<FrameRecord>& records () const { return records_; }

  /** \brief Reads frame \a i (0-based). Throws cuefusion::Error naming the bad file. */
  RGBDFrame::Ptr readFrame (std::size_t i) const;

  /** \brief 0 = trigger mode (default); > 0 plays at that rate when started. */
  void setFramesPerSecond (float fps);
  /** \brief Use only the first \a n frames (0 = all). */
  void setFrameLimit (std::size_t n);

  /** \brief Trigger mode: reads and emits the next frame. False when none is left
    * (or the grabber is not started). Errors propagate as cuefusion::Error.
    */
  bool trigger ();

  void start () override;
  void stop () override;
  bool isRunning () const override;
  std::string getName () const override;
  float getFramesPerSecond () const override { return fps_; }
  bool hasMoreFrames () const override;
  std::string lastError () const override;

protected:
  DatasetGrabber (const std::string& root);

  /** \brief Checks the index is not empty, takes the image size from the first depth
    * image when the intrinsics file has none, and prepares colour registration.
    */
  void finishSetup ();

  std::string root_;
  std::vector<FrameRecord> records_;
  PinholeCamera camera_;
  double depth_units_per_metre_ = 1000.0;
  /** Intrinsics of a colour camera whose images differ in size from depth (ScanNet). */
  std::optional<PinholeCamera> color_camera_;

private:
  cv::Mat registerToDepth (const cv::Mat& image, const std::string& path, bool nearest) const;
  void playRealTime ();

  std::size_t limit_ = 0;
  float fps_ = 0.f;
  std::atomic<bool> running_{false};
  std::atomic<std::size_t> next_{0};
  std::thread thread_;
  mutable std::mutex error_mutex_;
  std::string last_error_;
  cv::Mat map_x_, map_y_;  ///< depth pixel → colour pixel (colour registration)
};
}  // namespace io
}  // namespace cuefusion
