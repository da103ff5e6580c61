// SPDX-License-Identifier: BSD-3-Clause
#pragma once

#include <cuefusion/common/rgbd_frame.h>

#include <pcl/io/grabber.h>

#include <memory>
#include <string>

namespace cuefusion
{
namespace io
{
/** \brief Base of every cuefusion grabber: a pcl::Grabber with two signals.
  *
  * - sig_cb_rgbd_frame: the registered RGBDFrame (depth in metres, BGR colour, pose and
  *   masks when the source has them)
  * - sig_cb_point_cloud_rgba: the same frame as an organized pcl::PointXYZRGBA cloud
  *   (only built when a slot is connected)
  *
  * \code
  * grabber->registerCallback (std::function<cuefusion::io::RGBDGrabber::sig_cb_rgbd_frame> (
  *     [] (const cuefusion::RGBDFrame::ConstPtr& f) { ... }));
  * \endcode
  */
class RGBDGrabber : public pcl::Grabber
{
public:
  using Ptr = std::shared_ptr<RGBDGrabber>;
  using sig_cb_rgbd_frame = void (const RGBDFrame::ConstPtr&);
  using sig_cb_point_cloud_rgba = void (const pcl::PointCloud<pcl::PointXYZRGBA>::ConstPtr&);

  RGBDGrabber ();
  ~RGBDGrabber () override;

  /** \brief Short name of the source format: "tum", "redwood", "7scenes", "scannet", "openni2". */
  virtual std::string formatName () const = 0;

  /** \brief False once an offline sequence is exhausted or a live device stopped. */
  virtual bool hasMoreFrames () const = 0;

  /** \brief Message of the error that stopped a background thread ("" if none). */
  virtual std::string lastError () const { return ""; }

protected:
  /** \brief Emits \a frame on both signals (the cloud only when someone listens). */
  void publish (const RGBDFrame::ConstPtr& frame);

private:
  boost::signals2::signal<sig_cb_rgbd_frame>* frame_signal_;
  boost::signals2::signal<sig_cb_point_cloud_rgba>* cloud_signal_;
};
}  // namespace io
}  // namespace cuefusion
