// SPDX-License-Identifier: BSD-3-Clause
// libcuefusion_run_display.so: the live viewer window and the video file of `run`, loaded
// by loadRunDisplay (run_display.cpp) only when --view or --video asks for them.
#include "run_display.h"

#include <cuefusion/common/exceptions.h>
#include <cuefusion/common/quiet_opencv_log.h>
#include <cuefusion/viewer/live_viewer.h>

#include <boost/filesystem.hpp>
#include <opencv2/videoio.hpp>
#include <opencv2/videoio/registry.hpp>

#include <cstdint>
#include <cstring>
#include <fstream>

namespace fs = boost::filesystem;

namespace cuefusion
{
namespace cli
{
namespace
{
/** Whether the file's top-level container structure is whole: an AVI's RIFF chunks (and
  * AVIX extensions), an MP4's boxes with its 'moov' index, each within the file. Reading
  * the frames back with OpenCV would print FFmpeg's or OpenCV's complaints on stderr. */
bool
containerComplete (const std::string& path, bool avi)
{
  std::ifstream in (path, std::ios::binary);
  in.seekg (0, std::ios::end);
  const std::uint64_t size = static_cast<std::uint64_t> (in.tellg ());
  in.seekg (0);
  std::uint64_t at = 0;
  bool moov = false;
  while (at < size)
  {
    unsigned char head[16] = {};
    in.seekg (static_cast<std::streamoff> (at));
    if (size - at < 8 || !in.read (reinterpret_cast<char*> (head), 8))
      return false;
    std::uint64_t length = 0;
    if (avi)  // 'RIFF', little-endian size of what follows, padded to even
    {
      if (std::memcmp (head, "RIFF", 4) != 0)
        return false;
      length = 8 + (std::uint64_t (head[4]) | std::uint64_t (head[5]) << 8 | std::uint64_t (head[6]) << 16 | std::uint64_t (head[7]) << 24);
      length += length & 1u;
    }
    else  // big-endian box size (1: a 64-bit size follows; 0: to the end), then the type
    {
      length = std::uint64_t (head[0]) << 24 | std::uint64_t (head[1]) << 16 | std::uint64_t (head[2]) << 8 | head[3];
      moov = moov || std::memcmp (head + 4, "moov", 4) == 0;
      if (length == 0)
        length = size - at;
      else if (length == 1)
      {
        if (size - at < 16 || !in.read (reinterpret_cast<char*> (head + 8), 8))
          return false;
        length = 0;
        for (int k = 8; k < 16; ++k)
          length = length << 8 | head[k];
      }
      if (length < 8)
        return false;
    }
    if (length > size - at)
      return false;
    at += length;
  }
  return size > 0 && (avi || moov);
}

/** Frames go to a temporary file next to the target, renamed into place when the run ends
  * well (a failed run leaves no half-written video). The container follows the extension:
  * .avi → Motion-JPEG (always available in OpenCV), .mp4 → MPEG-4 part 2. */
class VideoFile : public VideoSink
{
public:
  VideoFile (const std::string& path, double fps) : path_ (path), fps_ (fps)
  {
    const std::string ext = fs::path (path).extension ().string ();
    if (ext == ".avi")
      fourcc_ = cv::VideoWriter::fourcc ('M', 'J', 'P', 'G');
    else if (ext == ".mp4")
      fourcc_ = cv::VideoWriter::fourcc ('m', 'p', '4', 'v');
    else
      throw Error (path, "a video must end in .avi or .mp4, not '" + ext + "'");
    const fs::path target (path);
    boost::system::error_code ec;
    if (!target.parent_path ().empty () && !fs::is_directory (target.parent_path (), ec) &&
        (!fs::create_directories (target.parent_path (), ec) || ec))
      throw Error (path, "cannot create its folder" + (ec ? ": " + ec.message () : std::string ()));
    const fs::file_status status = fs::status (target, ec);
    if (fs::exists (status) && !fs::is_regular_file (status))  // renaming over it would replace a device or folder
      throw Error (path, "exists and is not a regular file; refusing to replace it");
    temporary_ = (target.parent_path () / fs::unique_path ("." + target.stem ().string () + ".tmp-%%%%%%" + ext)).string ();
  }
  ~VideoFile () override
  {
    if (writer_.isOpened ())
      writer_.release ();
    if (!finished_)
    {
      boost::system::error_code ec;
      fs::remove (temporary_, ec);
    }
  }
  void write (const cv::Mat& image) override
  {
    if (!writer_.isOpened ())
    {
      // A backend of OpenCV's own for Motion-JPEG, FFmpeg's for MPEG-4: never GStreamer,
      // whose messages (and OpenCV's about it) would precede or replace cuefusion's line.
      const bool mjpeg = fourcc_ == cv::VideoWriter::fourcc ('M', 'J', 'P', 'G');
      const int backend = mjpeg ? cv::CAP_OPENCV_MJPEG
                                : (cv::videoio_registry::hasBackend (cv::CAP_FFMPEG) ? cv::CAP_FFMPEG : cv::CAP_ANY);
      bool opened = false;
      try
      {
        const QuietOpenCVLog quiet;
        opened = writer_.open (temporary_, backend, fourcc_, fps_, image.size ());
      }
      catch (const cv::Exception&)
      {
        opened = false;
      }
      if (!opened)
        throw Error (path_, "OpenCV cannot write this video format here");
      size_ = image.size ();
    }
    if (image.size () != size_)
      throw Error (path_, "frame size changed during the run");
    writer_.write (image);
    ++frames_;
  }
  void finish () override
  {
    if (!writer_.isOpened ())
      return;
    writer_.release ();
    // OpenCV's writer reports no write error: a full disk leaves a cut-short file.
    if (!containerComplete (temporary_, fourcc_ == cv::VideoWriter::fourcc ('M', 'J', 'P', 'G')))
      throw Error (path_, "the video file was cut short while " + std::to_string (frames_) +
                            " frames were written (is the disk full?)");
    boost::system::error_code ec;
    fs::rename (temporary_, path_, ec);
    if (ec)
      throw Error (path_, "cannot move the finished video into place: " + ec.message ());
    finished_ = true;
  }

private:
  std::string path_, temporary_;
  double fps_;
  int fourcc_ = 0;
  cv::Size size_;
  cv::VideoWriter writer_;
  bool finished_ = false;
  long long frames_ = 0;
};

class LiveViewerWindow : public ViewerWindow
{
public:
  explicit LiveViewerWindow (const std::string& title) : viewer_ (title) {}
  void postMap (const pcl::PointCloud<pcl::PointXYZRGBL>::ConstPtr& map) override { viewer_.postMap (map); }
  void postFrame (const PinholeCamera& camera, const Eigen::Isometry3d& pose,
                  const pcl::PointCloud<pcl::PointXYZRGBA>::ConstPtr& points) override
  {
    viewer_.postFrame (camera, pose, points);
  }
  bool spinOnce (int ms) override { return viewer_.spinOnce (ms); }
  void setFollowCamera (bool follow) override { viewer_.setFollowCamera (follow); }
  void saveScreenshot (const std::string& path) override { viewer_.saveScreenshot (path); }

private:
  viewer::LiveViewer viewer_;
};

class Display : public RunDisplay
{
public:
  std::unique_ptr<VideoSink> openVideo (const std::string& path, double fps) const override
  {
    return std::make_unique<VideoFile> (path, fps);
  }
  std::unique_ptr<ViewerWindow> openViewer (const std::string& title) const override
  {
    return std::make_unique<LiveViewerWindow> (title);
  }
};
}  // namespace
}  // namespace cli
}  // namespace cuefusion

extern "C" __attribute__ ((visibility ("default"))) const cuefusion::cli::RunDisplay*
cuefusion_run_display ()
{
  static const cuefusion::cli::Display display;
  return &display;
}
