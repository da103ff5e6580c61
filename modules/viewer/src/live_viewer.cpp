// SPDX-License-Identifier: BSD-3-Clause
#include <cuefusion/common/exceptions.h>
#include <cuefusion/common/label_colors.h>
#include <cuefusion/viewer/live_viewer.h>

#include <pcl/visualization/pcl_visualizer.h>
#include <vtkCamera.h>
#include <vtkRenderer.h>
#include <vtkRendererCollection.h>

#include <cmath>
#include <cstdlib>

namespace cuefusion
{
namespace viewer
{
bool
LiveViewer::displayAvailable ()
{
  const char* display = std::getenv ("DISPLAY");
  return display != nullptr && *display != '\0';
}

LiveViewer::LiveViewer (const std::string& title, int width, int height)
{
  // Without a display VTK aborts the process; say so instead.
  if (!displayAvailable ())
    throw Error ("--view", "no display (DISPLAY is not set); run under xvfb-run for an off-screen window, or drop --view");
  viewer_ = std::make_unique<pcl::visualization::PCLVisualizer> (title, false);
  // Left: the map with the camera frustum, followed from behind the camera. Right: the
  // current frame's points as the camera sees them.
  viewer_->createViewPort (0.0, 0.0, 0.7, 1.0, map_viewport_);
  viewer_->createViewPort (0.7, 0.5, 1.0, 1.0, frame_viewport_);
  viewer_->setBackgroundColor (0.12, 0.12, 0.14, map_viewport_);
  viewer_->setBackgroundColor (0.05, 0.05, 0.06, frame_viewport_);
  viewer_->addCoordinateSystem (0.2, "world", map_viewport_);
  viewer_->addText ("map segments", 10, 10, 14, 1.0, 1.0, 1.0, "map_title", map_viewport_);
  viewer_->addText ("current frame", 10, 10, 14, 1.0, 1.0, 1.0, "frame_title", frame_viewport_);
  viewer_->initCameraParameters ();
  viewer_->createInteractor ();
  viewer_->setSize (width, height);
  // PCL's viewports share one vtkCamera; the frame view gets its own, fixed at the
  // sensor's pose (origin, looking down +z, image y down).
  vtkRendererCollection* renderers = viewer_->getRendererCollection ();
  renderers->InitTraversal ();
  for (int i = 0; vtkRenderer* renderer = renderers->GetNextItem (); ++i)
    if (i == frame_viewport_)
    {
      frame_renderer_ = renderer;
      vtkSmartPointer<vtkCamera> camera = vtkSmartPointer<vtkCamera>::New ();
      camera->SetPosition (0.0, 0.0, 0.0);
      camera->SetFocalPoint (0.0, 0.0, 1.0);
      camera->SetViewUp (0.0, -1.0, 0.0);
      renderer->SetActiveCamera (camera);
    }
}

// PCLVisualizer::close () crashes in PCL 1.13's X interactor (TerminateApp on a display
// already gone); destroying the visualizer closes the window without it.
LiveViewer::~LiveViewer () = default;

void
LiveViewer::postMap (const Cloud::ConstPtr& map)
{
  const std::lock_guard<std::mutex> lock (mutex_);
  pending_map_ = map;
}

void
LiveViewer::postFrame (const PinholeCamera& camera, const Eigen::Isometry3d& pose, const FrameCloud::ConstPtr& points)
{
  const std::lock_guard<std::mutex> lock (mutex_);
  pending_camera_ = camera;
  pending_pose_ = pose;
  pending_points_ = points;
  have_frame_ = true;
}

void
LiveViewer::followCamera (const Eigen::Isometry3d& pose)
{
  // 0.6 m behind and 0.3 m above the camera, looking at a point 1.5 m in front of it.
  const Eigen::Vector3d eye = pose * Eigen::Vector3d (0.0, -0.3, -0.6);
  const Eigen::Vector3d focus = pose * Eigen::Vector3d (0.0, 0.0, 1.5);
  const Eigen::Vector3d up = -pose.linear ().col (1);
  viewer_->setCameraPosition (eye.x (), eye.y (), eye.z (), focus.x (), focus.y (), focus.z (), up.x (), up.y (), up.z (), map_viewport_);
}

void
LiveViewer::drawFrustum (const PinholeCamera& camera, const Eigen::Isometry3d& pose)
{
  const double depth = 0.3;
  const Eigen::Vector3d corners_px[4] = {{0, 0, 1}, {static_cast<double> (camera.width), 0, 1},
                                         {static_cast<double> (camera.width), static_cast<double> (camera.height), 1},
                                         {0, static_cast<double> (camera.height), 1}};
  pcl::PointXYZ apex;
  apex.getVector3fMap () = pose.translation ().cast<float> ();
  pcl::PointXYZ corners[4];
  for (int k = 0; k < 4; ++k)
  {
    const Eigen::Vector3d ray ((corners_px[k].x () - camera.cx) / camera.fx, (corners_px[k].y () - camera.cy) / camera.fy, 1.0);
    corners[k].getVector3fMap () = (pose * (ray * depth)).cast<float> ();
  }
  for (int k = 0; k < 4; ++k)
  {
    const std::string side = "frustum_side_" + std::to_string (k), rim = "frustum_rim_" + std::to_string (k);
    viewer_->removeShape (side);
    viewer_->removeShape (rim);
    viewer_->addLine (apex, corners[k], 1.0, 0.85, 0.1, side, map_viewport_);
    viewer_->addLine (corners[k], corners[(k + 1) % 4], 1.0, 0.85, 0.1, rim, map_viewport_);
  }
}

bool
LiveViewer::spinOnce (int ms)
{
  Cloud::ConstPtr map;
  FrameCloud::ConstPtr points;
  PinholeCamera camera;
  Eigen::Isometry3d pose;
  bool frame = false;
  {
    const std::lock_guard<std::mutex> lock (mutex_);
    map.swap (pending_map_);
    points.swap (pending_points_);
    frame = have_frame_;
    have_frame_ = false;
    camera = pending_camera_;
    pose = pending_pose_;
  }
  if (map && !map->empty ())
  {
    // Colour by segment with the project's fixed palette (label 0 grey).
    pcl::PointCloud<pcl::PointXYZRGB>::Ptr colored = pcl::make_shared<pcl::PointCloud<pcl::PointXYZRGB>> ();
    colored->resize (map->size ());
    for (std::size_t i = 0; i < map->size (); ++i)
    {
      const auto& p = (*map)[i];
      auto& q = (*colored)[i];
      q.x = p.x;
      q.y = p.y;
      q.z = p.z;
      const cv::Vec3b c = p.label ? labelColor (p.label) : cv::Vec3b (128, 128, 128);
      q.r = c[0];
      q.g = c[1];
      q.b = c[2];
    }
    if (!viewer_->updatePointCloud (colored, "map"))
      viewer_->addPointCloud (colored, "map", map_viewport_);
    viewer_->setPointCloudRenderingProperties (pcl::visualization::PCL_VISUALIZER_POINT_SIZE, 2, "map");
  }
  if (frame)
  {
    drawFrustum (camera, pose);
    if (follow_)
      followCamera (pose);
    last_pose_ = pose;
    if (points && !points->empty ())
    {
      if (frame_renderer_)
      {
        frame_renderer_->GetActiveCamera ()->SetViewAngle (2.0 * std::atan (0.5 * camera.height / camera.fy) * 180.0 / M_PI);
        frame_renderer_->ResetCameraClippingRange ();
      }
      pcl::visualization::PointCloudColorHandlerRGBField<pcl::PointXYZRGBA> rgb (points);
      if (!viewer_->updatePointCloud (points, rgb, "frame"))
        viewer_->addPointCloud (points, rgb, "frame", frame_viewport_);
    }
  }
  viewer_->spinOnce (ms, true);
  return !viewer_->wasStopped ();
}

void
LiveViewer::setFollowCamera (bool follow)
{
  follow_ = follow;
  if (follow_)
    followCamera (last_pose_);
}

void
LiveViewer::saveScreenshot (const std::string& path)
{
  viewer_->spinOnce (1, true);
  viewer_->saveScreenshot (path);
}
}  // namespace viewer
}  // namespace cuefusion
