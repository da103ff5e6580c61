// SPDX-License-Identifier: BSD-3-Clause
#pragma once

#include <cuefusion/common/pinhole_camera.h>

#include <Eigen/Geometry>
#include <pcl/point_cloud.h>
#include <pcl/point_types.h>

#include <memory>
#include <mutex>
#include <string>

class vtkRenderer;

namespace pcl
{
namespace visualization
{
class PCLVisualizer;
}
}  // namespace pcl

namespace cuefusion
{
namespace viewer
{
/** \brief A PCLVisualizer window showing the labelled map growing, the camera frustum and
  * the current frame's points. VTK wants its window on the thread that made it, so the
  * viewer lives on the main thread (construct it there and call spinOnce in a loop) while
  * processing runs on another thread and hands over data with the post… calls, which
  * only copy under a mutex and never touch VTK.
  */
class LiveViewer
{
public:
  using Cloud = pcl::PointCloud<pcl::PointXYZRGBL>;
  using FrameCloud = pcl::PointCloud<pcl::PointXYZRGBA>;

  /** \brief Throws cuefusion::Error when there is no display (DISPLAY unset). */
  LiveViewer (const std::string& title, int width = 1280, int height = 720);
  ~LiveViewer ();
  LiveViewer (const LiveViewer&) = delete;
  LiveViewer& operator= (const LiveViewer&) = delete;

  /** \brief True when a display is available to open a window on. */
  static bool displayAvailable ();

  /** \brief Thread-safe: the map (labels coloured by labelColor) to show next. */
  void postMap (const Cloud::ConstPtr& map);
  /** \brief Thread-safe: the camera (pose camera-to-world) and the current frame's points
    * in the camera frame, drawn at the next spinOnce. */
  void postFrame (const PinholeCamera& camera, const Eigen::Isometry3d& pose, const FrameCloud::ConstPtr& points);

  /** \brief Main thread: draws what was posted and handles events for \a ms. False once
    * the user closed the window. */
  bool spinOnce (int ms = 20);
  /** \brief Main thread: whether the map view follows the camera (from 0.6 m behind and
    * 0.3 m above it; the default) or is left to the mouse. */
  void setFollowCamera (bool follow);
  /** \brief Main thread: renders and writes the window's picture as PNG. */
  void saveScreenshot (const std::string& path);

private:
  void drawFrustum (const PinholeCamera& camera, const Eigen::Isometry3d& pose);
  void followCamera (const Eigen::Isometry3d& pose);

  std::unique_ptr<pcl::visualization::PCLVisualizer> viewer_;
  std::mutex mutex_;
  Cloud::ConstPtr pending_map_;
  FrameCloud::ConstPtr pending_points_;
  PinholeCamera pending_camera_;
  Eigen::Isometry3d pending_pose_ = Eigen::Isometry3d::Identity ();
  bool have_frame_ = false;
  bool follow_ = true;
  Eigen::Isometry3d last_pose_ = Eigen::Isometry3d::Identity ();
  int map_viewport_ = 0;
  int frame_viewport_ = 0;
  vtkRenderer* frame_renderer_ = nullptr;  ///< owned by the visualizer
};
}  // namespace viewer
}  // namespace cuefusion
