// SPDX-License-Identifier: BSD-3-Clause
#include <cuefusion/io/rgbd_grabber.h>

namespace cuefusion
{
namespace io
{
RGBDGrabber::RGBDGrabber ()
  : frame_signal_ (createSignal<sig_cb_rgbd_frame> ()), cloud_signal_ (createSignal<sig_cb_point_cloud_rgba> ())
{}

RGBDGrabber::~RGBDGrabber () = default;

void
RGBDGrabber::publish (const RGBDFrame::ConstPtr& frame)
{
  if (frame_signal_->num_slots () > 0)
    (*frame_signal_) (frame);
  if (cloud_signal_->num_slots () > 0)
    (*cloud_signal_) (toPointCloud (*frame));
}
}  // namespace io
}  // namespace cuefusion
