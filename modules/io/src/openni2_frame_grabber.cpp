// SPDX-License-Identifier: BSD-3-Clause
#include <cuefusion/common/exceptions.h>
#include <cuefusion/io/openni2_frame_grabber.h>

#include <pcl/io/openni2_grabber.h>

#include <boost/algorithm/string/predicate.hpp>
#include <boost/filesystem.hpp>

#include <opencv2/imgproc.hpp>

namespace cuefusion
{
namespace io
{
OpenNI2FrameGrabber::OpenNI2FrameGrabber (const std::string& device) : device_ (device)
{
  if (boost::algorithm::iends_with (device, ".oni") && !boost::filesystem::is_regular_file (device))
    throw Error (device, "no such .oni recording");
  try
  {
    grabber_ = std::make_unique<pcl::io::OpenNI2Grabber> (device);
  }
  catch (const pcl::PCLException& e)
  {
    // PCL's message is "function in file @ line : reason", and OpenNI's own log may
    // follow on further lines; keep the reason's first line.
    std::string reason = e.what ();
    const auto colon = reason.find (" : ");
    if (colon != std::string::npos)
      reason = reason.substr (colon + 3);
    reason = reason.substr (0, reason.find ('\n'));
    const std::string where = boost::algorithm::iends_with (device, ".oni") ? device : "openni2:" + device;
    throw Error (device.empty () ? "openni2" : where, "cannot open OpenNI2 device: " + reason);
  }
  std::function<pcl::io::OpenNI2Grabber::sig_cb_openni_image_depth_image> callback =
    [this] (const pcl::io::Image::Ptr& image, const pcl::io::DepthImage::Ptr& depth, float rfl) {
      onImages (image, depth, rfl);
    };
  grabber_->registerCallback (callback);
}

OpenNI2FrameGrabber::~OpenNI2FrameGrabber ()
{
  if (grabber_ && grabber_->isRunning ())
    grabber_->stop ();
}

void
OpenNI2FrameGrabber::start ()
{
  grabber_->start ();
}

void
OpenNI2FrameGrabber::stop ()
{
  grabber_->stop ();
}

bool
OpenNI2FrameGrabber::isRunning () const
{
  return grabber_->isRunning ();
}

float
OpenNI2FrameGrabber::getFramesPerSecond () const
{
  return grabber_->getFramesPerSecond ();
}

void
OpenNI2FrameGrabber::onImages (const pcl::io::Image::Ptr& image, const pcl::io::DepthImage::Ptr& depth,
                               float reciprocal_focal_length)
{
  const int w = static_cast<int> (depth->getWidth ());
  const int h = static_cast<int> (depth->getHeight ());
  auto frame = std::make_shared<RGBDFrame> ();
  frame->index = frames_++;
  frame->timestamp = static_cast<double> (depth->getTimestamp ()) * 1e-6;
  frame->name = std::to_string (frame->index);
  // Same model PCL uses for the device's own clouds: one focal length, centred.
  const double f = 1.0 / reciprocal_focal_length;
  frame->camera = PinholeCamera (f, f, (w - 1) * 0.5, (h - 1) * 0.5, w, h);

  cv::Mat raw (h, w, CV_16UC1);
  depth->fillDepthImageRaw (static_cast<unsigned> (w), static_cast<unsigned> (h), raw.ptr<unsigned short> ());
  raw.convertTo (frame->depth, CV_32F, 1.0 / 1000.0);

  cv::Mat rgb (static_cast<int> (image->getHeight ()), static_cast<int> (image->getWidth ()), CV_8UC3);
  image->fillRGB (image->getWidth (), image->getHeight (), rgb.data);
  cv::cvtColor (rgb, frame->color, cv::COLOR_RGB2BGR);
  if (frame->color.size () != frame->depth.size ())
    cv::resize (frame->color, frame->color, frame->depth.size (), 0, 0, cv::INTER_AREA);
  publish (frame);
}
}  // namespace io
}  // namespace cuefusion
