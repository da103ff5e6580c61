// SPDX-License-Identifier: BSD-3-Clause
#pragma once

#include <cuefusion/io/rgbd_grabber.h>

#include <atomic>
#include <memory>
#include <mutex>
#include <string>

namespace pcl
{
namespace io
{
class OpenNI2Grabber;
class Image;
class DepthImage;
}  // namespace io
}  // namespace pcl

namespace cuefusion
{
namespace io
{
/** \brief Live OpenNI2 devices (Kinect, Xtion, PrimeSense) and .oni recordings through
  * pcl::io::OpenNI2Grabber, delivered as RGBDFrames on the same signals as the
  * dataset grabbers. Depth is registered to colour by the device when it can.
  */
class OpenNI2FrameGrabber : public RGBDGrabber
{
public:
  /** \param device "" for the first device, "#N" for the N-th, a device URI, or a path
    * to a .oni file. Throws cuefusion::Error when no such device or file exists.
    */
  explicit OpenNI2FrameGrabber (const std::string& device);
  ~OpenNI2FrameGrabber () override;

  void start () override;
  void stop () override;
  bool isRunning () const override;
  std::string getName () const override { return "cuefusion OpenNI2 grabber"; }
  float getFramesPerSecond () const override;
  std::string formatName () const override { return "openni2"; }
  bool hasMoreFrames () const override { return isRunning (); }

private:
  void onImages (const std::shared_ptr<pcl::io::Image>& image, const std::shared_ptr<pcl::io::DepthImage>& depth,
                 float reciprocal_focal_length);

  std::string device_;
  std::unique_ptr<pcl::io::OpenNI2Grabber> grabber_;
  std::atomic<std::size_t> frames_{0};
};
}  // namespace io
}  // namespace cuefusion
