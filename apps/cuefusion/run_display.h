// SPDX-License-Identifier: BSD-3-Clause
#pragma once

#include <cuefusion/common/pinhole_camera.h>

#include <Eigen/Geometry>
#include <opencv2/core.hpp>
#include <pcl/point_cloud.h>
#include <pcl/point_types.h>

#include <memory>
#include <string>

namespace cuefusion
{
namespace cli
{
/** `run --video`: the frames' panels as a video file, renamed into place by finish(). */
class VideoSink
{
public:
  virtual ~VideoSink () = default;
  virtual void write (const cv::Mat& panel) = 0;
  virtual void finish () = 0;
};

/** `run --view`: the live viewer window (viewer::LiveViewer), main thread only
  * except the post… calls. */
class ViewerWindow
{
public:
  virtual ~ViewerWindow () = default;
  virtual void postMap (const pcl::PointCloud<pcl::PointXYZRGBL>::ConstPtr& map) = 0;
  virtual void postFrame (const PinholeCamera& camera, const Eigen::Isometry3d& pose,
                          const pcl::PointCloud<pcl::PointXYZRGBA>::ConstPtr& points) = 0;
  virtual bool spinOnce (int ms) = 0;
  virtual void setFollowCamera (bool follow) = 0;
  virtual void saveScreenshot (const std::string& path) = 0;
};

/** What `run` shows and records beside its outputs. The window needs VTK and Qt, the video
  * OpenCV's video I/O: about 70 MB of libraries resident once loaded, which every command
  * paid at start-up while they were linked in. They live in a library of their own
  * (libcuefusion_run_display.so, in cuefusion/ beside the cuefusion libraries), loaded by loadRunDisplay
  * only when --view or --video asks for it. */
class RunDisplay
{
public:
  virtual ~RunDisplay () = default;
  /** Throws cuefusion::Error naming \a path when the format cannot be written. */
  virtual std::unique_ptr<VideoSink> openVideo (const std::string& path, double fps) const = 0;
  /** Throws cuefusion::Error when there is no display. */
  virtual std::unique_ptr<ViewerWindow> openViewer (const std::string& title) const = 0;
};

/** The display library, loaded on the first call (plugin.h). Throws cuefusion::Error
  * naming the library and the loader's reason when it cannot be loaded. */
const RunDisplay&
loadRunDisplay ();

/** The symbol the display library exports: `extern "C" const RunDisplay* NAME ()`. */
constexpr const char* kRunDisplayLibrary = "libcuefusion_run_display.so";
constexpr const char* kRunDisplaySymbol = "cuefusion_run_display";
}  // namespace cli
}  // namespace cuefusion
