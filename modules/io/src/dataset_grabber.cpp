// SPDX-License-Identifier: BSD-3-Clause
#include <cuefusion/common/exceptions.h>
#include <cuefusion/io/dataset_grabber.h>
#include <cuefusion/io/file_io.h>
#include <cuefusion/io/pose_io.h>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <chrono>
#include <cmath>

namespace cuefusion
{
namespace io
{
namespace
{
/** Largest relative difference of a colour image's horizontal and vertical scale to the
  * depth image that is still taken as the same field of view. */
constexpr double kAspectTolerance = 0.01;
}  // namespace

DatasetGrabber::DatasetGrabber (const std::string& root) : root_ (root) {}

DatasetGrabber::~DatasetGrabber () { stop (); }

std::size_t
DatasetGrabber::size () const
{
  return limit_ > 0 ? std::min (limit_, records_.size ()) : records_.size ();
}

bool
DatasetGrabber::hasPoses () const
{
  for (const FrameRecord& r : records_)
    if (r.pose || !r.pose_path.empty ())
      return true;
  return false;
}

bool
DatasetGrabber::hasInstanceMasks () const
{
  for (const FrameRecord& r : records_)
    if (!r.instance_path.empty ())
      return true;
  return false;
}

void
DatasetGrabber::finishSetup ()
{
  if (records_.empty ())
    throw Error (root_, "the " + formatName () + " sequence has no frames");
  if (camera_.width == 0 || camera_.height == 0)
  {
    const cv::Mat first = readDepthImage (records_.front ().depth_path, depth_units_per_metre_);
    camera_.width = first.cols;
    camera_.height = first.rows;
  }
  camera_.validate (root_);
  if (!color_camera_)
    return;
  // The colour camera shares the depth camera's optical centre (ScanNet's exports keep
  // identity extrinsics), so the depth→colour pixel map does not depend on depth.
  const cv::Mat first_color = readImage (records_.front ().color_path, cv::IMREAD_COLOR);
  PinholeCamera& cc = *color_camera_;
  if (cc.width == 0 || cc.height == 0)
  {
    cc.width = first_color.cols;
    cc.height = first_color.rows;
  }
  cc.validate (root_);
  if (cc.width == camera_.width && cc.height == camera_.height && cc.fx == camera_.fx && cc.fy == camera_.fy &&
      cc.cx == camera_.cx && cc.cy == camera_.cy)
    return;
  map_x_.create (camera_.height, camera_.width, CV_32F);
  map_y_.create (camera_.height, camera_.width, CV_32F);
  for (int v = 0; v < camera_.height; ++v)
    for (int u = 0; u < camera_.width; ++u)
    {
      map_x_.at<float> (v, u) = static_cast<float> ((u - camera_.cx) / camera_.fx * cc.fx + cc.cx);
      map_y_.at<float> (v, u) = static_cast<float> ((v - camera_.cy) / camera_.fy * cc.fy + cc.cy);
    }
}

cv::Mat
DatasetGrabber::registerToDepth (const cv::Mat& image, const std::string& path, bool nearest) const
{
  // Masks already at depth resolution are taken as registered to depth.
  if (image.cols == camera_.width && image.rows == camera_.height && (map_x_.empty () || nearest))
    return image;
  if (!map_x_.empty ())
  {
    if (image.cols != color_camera_->width || image.rows != color_camera_->height)
      throw Error (path, "image is " + std::to_string (image.cols) + "x" + std::to_string (image.rows) +
                             " but the colour intrinsics are for " + std::to_string (color_camera_->width) + "x" +
                             std::to_string (color_camera_->height));
    cv::Mat out;
    cv::remap (image, out, map_x_, map_y_, nearest ? cv::INTER_NEAREST : cv::INTER_LINEAR, cv::BORDER_CONSTANT);
    return out;
  }
  // Same field of view at another resolution: the same aspect (within kAspectTolerance, the
  // rounding of sensors' crops, e.g. 1296x968 over 640x480), or the pixels would not meet
  // the depth's and labels would land on other surfaces.
  const double sx = static_cast<double> (image.cols) / camera_.width, sy = static_cast<double> (image.rows) / camera_.height;
  if (std::abs (sx - sy) > kAspectTolerance * std::max (sx, sy))
    throw Error (path, "image is " + std::to_string (image.cols) + "x" + std::to_string (image.rows) +
                           ", another aspect than the depth's " + std::to_string (camera_.width) + "x" +
                           std::to_string (camera_.height) + " (a colour camera of its own needs its intrinsics)");
  cv::Mat out;
  cv::resize (image, out, cv::Size (camera_.width, camera_.height), 0, 0, nearest ? cv::INTER_NEAREST : cv::INTER_AREA);
  return out;
}

RGBDFrame::Ptr
DatasetGrabber::readFrame (std::size_t i) const
{
  if (i >= size ())
    throw Error (root_, "frame " + std::to_string (i) + " out of range (sequence has " + std::to_string (size ()) + ")");
  const FrameRecord& r = records_[i];
  auto frame = std::make_shared<RGBDFrame> ();
  frame->index = i;
  frame->timestamp = r.timestamp;
  frame->name = r.name;
  frame->camera = camera_;
  frame->depth = readDepthImage (r.depth_path, depth_units_per_metre_);
  if (frame->depth.cols != camera_.width || frame->depth.rows != camera_.height)
    throw Error (r.depth_path, "depth image is " + std::to_string (frame->depth.cols) + "x" +
                                   std::to_string (frame->depth.rows) + " but the intrinsics are for " +
                                   std::to_string (camera_.width) + "x" + std::to_string (camera_.height));
  frame->color = registerToDepth (readImage (r.color_path, cv::IMREAD_COLOR), r.color_path, false);
  if (r.pose)
    frame->pose = r.pose;
  else if (!r.pose_path.empty ())
    frame->pose = readPoseMatrixFile (r.pose_path);
  if (!r.instance_path.empty ())
    frame->instance_mask = registerToDepth (readLabelImage (r.instance_path), r.instance_path, true);
  if (!r.class_path.empty ())
    frame->class_mask = registerToDepth (readLabelImage (r.class_path), r.class_path, true);
  return frame;
}

void
DatasetGrabber::setFramesPerSecond (float fps)
{
  if (!(fps >= 0.f) || !std::isfinite (fps))
    throw ParameterError ("frames per second", "must be 0 (trigger mode) or positive, got " + std::to_string (fps));
  fps_ = fps;
}

void
DatasetGrabber::setFrameLimit (std::size_t n)
{
  limit_ = n;
}

bool
DatasetGrabber::trigger ()
{
  if (!running_ || fps_ > 0.f)
    return false;
  const std::size_t i = next_;
  if (i >= size ())
  {
    running_ = false;
    return false;
  }
  next_ = i + 1;
  publish (readFrame (i));
  if (next_ >= size ())
    running_ = false;
  return true;
}

void
DatasetGrabber::start ()
{
  if (running_)
    return;
  if (thread_.joinable ())
    thread_.join ();
  next_ = 0;
  {
    std::lock_guard<std::mutex> lock (error_mutex_);
    last_error_.clear ();
  }
  running_ = size () > 0;
  if (running_ && fps_ > 0.f)
    thread_ = std::thread (&DatasetGrabber::playRealTime, this);
}

void
DatasetGrabber::stop ()
{
  running_ = false;
  if (thread_.joinable () && thread_.get_id () != std::this_thread::get_id ())
    thread_.join ();
}

bool
DatasetGrabber::isRunning () const
{
  return running_;
}

bool
DatasetGrabber::hasMoreFrames () const
{
  return running_ && next_ < size ();
}

std::string
DatasetGrabber::getName () const
{
  return "cuefusion " + formatName () + " grabber";
}

std::string
DatasetGrabber::lastError () const
{
  std::lock_guard<std::mutex> lock (error_mutex_);
  return last_error_;
}

void
DatasetGrabber::playRealTime ()
{
  using clock = std::chrono::steady_clock;
  const auto start = clock::now ();
  const auto period = std::chrono::duration<double> (1.0 / fps_);
  try
  {
    while (running_)
    {
      // The frame the clock says is due now; frames a slow consumer missed are skipped,
      // as a live camera would drop them.
      const double elapsed = std::chrono::duration<double> (clock::now () - start).count ();
      const std::size_t due = static_cast<std::size_t> (elapsed * fps_);
      const std::size_t i = std::max<std::size_t> (due, next_);
      if (i >= size ())
        break;
      next_ = i + 1;
      publish (readFrame (i));
      std::this_thread::sleep_until (start + std::chrono::duration_cast<clock::duration> (period * (i + 1)));
    }
  }
  catch (const std::exception& e)
  {
    std::lock_guard<std::mutex> lock (error_mutex_);
    last_error_ = describeException (e);
  }
  running_ = false;
}
}  // namespace io
}  // namespace cuefusion
