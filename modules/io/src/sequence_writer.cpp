// SPDX-License-Identifier: BSD-3-Clause
#include <cuefusion/common/exceptions.h>
#include <cuefusion/io/camera_io.h>
#include <cuefusion/io/file_io.h>
#include <cuefusion/io/sequence_writer.h>

#include <boost/filesystem.hpp>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include <cstdio>
#include <sstream>

namespace fs = boost::filesystem;

namespace cuefusion
{
namespace io
{
DatasetLayout
parseDatasetLayout (const std::string& name)
{
  if (name == "tum")
    return DatasetLayout::TUM;
  if (name == "scannet")
    return DatasetLayout::ScanNet;
  if (name == "redwood")
    return DatasetLayout::Redwood;
  if (name == "7scenes")
    return DatasetLayout::SevenScenes;
  throw ParameterError ("DatasetLayout", "unknown layout '" + name + "' (tum, scannet, redwood, 7scenes)");
}

namespace
{
std::string
path (const std::string& dir, const std::string& relative)
{
  return (fs::path (dir) / relative).string ();
}

void
makeDirs (const std::string& dir, std::initializer_list<const char*> subdirs)
{
  boost::system::error_code ec;
  fs::create_directories (dir, ec);
  for (const char* s : subdirs)
    fs::create_directories (fs::path (dir) / s, ec);
  if (ec)
    throw Error (dir, "cannot create folder: " + ec.message ());
}

std::string
zeroPadded (std::size_t i, int width)
{
  char buffer[32];
  std::snprintf (buffer, sizeof (buffer), "%0*zu", width, i);
  return buffer;
}

void
writeMasks (const RGBDFrame& f, const std::string& instance_path, const std::string& class_path)
{
  if (!f.instance_mask.empty ())
    writeImageAtomic (instance_path, f.instance_mask);
  if (!f.class_mask.empty ())
    writeImageAtomic (class_path, f.class_mask);
}

class TumWriter : public SequenceWriter
{
public:
  TumWriter (const std::string& dir, const PinholeCamera& c) : SequenceWriter (dir, c)
  {
    makeDirs (dir, {"rgb", "depth", "instance", "label"});
  }

  static std::string stamp (double t)
  {
    char buffer[32];
    std::snprintf (buffer, sizeof (buffer), "%.6f", t);
    return buffer;
  }
  std::string frameName (const RGBDFrame& f) const override { return stamp (f.timestamp); }

  void
  write (const RGBDFrame& f) override
  {
    const std::string name = frameName (f);
    const std::string depth_name = stamp (f.timestamp + kDepthDelay);
    writeImageAtomic (path (dir_, "rgb/" + name + ".png"), f.color);
    writeImageAtomic (path (dir_, "depth/" + depth_name + ".png"), depthToRaw (f.depth, 5000.0));
    writeMasks (f, path (dir_, "instance/" + name + ".png"), path (dir_, "label/" + name + ".png"));
    rgb_ << name << " rgb/" << name << ".png\n";
    depth_ << depth_name << " depth/" << depth_name << ".png\n";
    if (f.pose)
      trajectory_.push_back ({std::stod (name), *f.pose});
  }

  void
  finish () override
  {
    writeTextAtomic (path (dir_, "rgb.txt"), "# color images\n# timestamp filename\n" + rgb_.str ());
    writeTextAtomic (path (dir_, "depth.txt"), "# depth maps\n# timestamp filename\n" + depth_.str ());
    if (!trajectory_.empty ())
      writeTumTrajectory (path (dir_, "groundtruth.txt"), trajectory_);
    writeIntrinsicsLine (path (dir_, "intrinsics.txt"), camera_);
  }

private:
  static constexpr double kDepthDelay = 0.004;
  std::ostringstream rgb_, depth_;
  Trajectory trajectory_;
};

class ScanNetWriter : public SequenceWriter
{
public:
  ScanNetWriter (const std::string& dir, const PinholeCamera& c) : SequenceWriter (dir, c)
  {
    makeDirs (dir, {"color", "depth", "pose", "intrinsic", "instance-filt", "label-filt"});
  }
  std::string frameName (const RGBDFrame& f) const override { return std::to_string (f.index); }

  void
  write (const RGBDFrame& f) override
  {
    const std::string n = frameName (f);
    cv::Mat color, instance, label;
    cv::resize (f.color, color, cv::Size (), 2.0, 2.0, cv::INTER_NEAREST);
    writeImageAtomic (path (dir_, "color/" + n + ".jpg"), color, {cv::IMWRITE_JPEG_QUALITY, 95});
    writeImageAtomic (path (dir_, "depth/" + n + ".png"), depthToRaw (f.depth, 1000.0));
    if (f.pose)
      writePoseMatrixFile (path (dir_, "pose/" + n + ".txt"), *f.pose);
    if (!f.instance_mask.empty ())
      cv::resize (f.instance_mask, instance, cv::Size (), 2.0, 2.0, cv::INTER_NEAREST);
    if (!f.class_mask.empty ())
      cv::resize (f.class_mask, label, cv::Size (), 2.0, 2.0, cv::INTER_NEAREST);
    RGBDFrame upscaled;
    upscaled.instance_mask = instance;
    upscaled.class_mask = label;
    writeMasks (upscaled, path (dir_, "instance-filt/" + n + ".png"), path (dir_, "label-filt/" + n + ".png"));
  }

  void
  finish () override
  {
    writeIntrinsicsMatrix (path (dir_, "intrinsic/intrinsic_depth.txt"), camera_, 4);
    writeIntrinsicsMatrix (path (dir_, "intrinsic/intrinsic_color.txt"),
                           camera_.scaled (2 * camera_.width, 2 * camera_.height), 4);
  }
};

class RedwoodWriter : public SequenceWriter
{
public:
  RedwoodWriter (const std::string& dir, const PinholeCamera& c) : SequenceWriter (dir, c)
  {
    makeDirs (dir, {"depth", "image", "instance", "label"});
  }
  std::string frameName (const RGBDFrame& f) const override { return zeroPadded (f.index, 5); }

  void
  write (const RGBDFrame& f) override
  {
    const std::string n = frameName (f);
    writeImageAtomic (path (dir_, "image/" + n + ".png"), f.color);
    writeImageAtomic (path (dir_, "depth/" + n + ".png"), depthToRaw (f.depth, 1000.0));
    writeMasks (f, path (dir_, "instance/" + n + ".png"), path (dir_, "label/" + n + ".png"));
    if (f.pose)
      poses_.push_back (*f.pose);
  }

  void
  finish () override
  {
    if (!poses_.empty ())
      writeRedwoodLog (path (dir_, "trajectory.log"), poses_);
    writeIntrinsicsJson (path (dir_, "camera_intrinsics.json"), camera_);
  }

private:
  PoseList poses_;
};

class SevenScenesWriter : public SequenceWriter
{
public:
  SevenScenesWriter (const std::string& dir, const PinholeCamera& c) : SequenceWriter (dir, c) { makeDirs (dir, {}); }
  std::string frameName (const RGBDFrame& f) const override { return "frame-" + zeroPadded (f.index, 6); }

  void
  write (const RGBDFrame& f) override
  {
    const std::string n = frameName (f);
    writeImageAtomic (path (dir_, n + ".color.png"), f.color);
    writeImageAtomic (path (dir_, n + ".depth.png"), depthToRaw (f.depth, 1000.0));
    if (f.pose)
      writePoseMatrixFile (path (dir_, n + ".pose.txt"), *f.pose);
    writeMasks (f, path (dir_, n + ".instance.png"), path (dir_, n + ".label.png"));
  }

  void
  finish () override
  {
    writeIntrinsicsMatrix (path (dir_, "camera-intrinsics.txt"), camera_, 3);
  }
};
}  // namespace

std::unique_ptr<SequenceWriter>
SequenceWriter::create (DatasetLayout layout, const std::string& dir, const PinholeCamera& camera)
{
  switch (layout)
  {
    case DatasetLayout::TUM: return std::make_unique<TumWriter> (dir, camera);
    case DatasetLayout::ScanNet: return std::make_unique<ScanNetWriter> (dir, camera);
    case DatasetLayout::Redwood: return std::make_unique<RedwoodWriter> (dir, camera);
    case DatasetLayout::SevenScenes: return std::make_unique<SevenScenesWriter> (dir, camera);
  }
  throw ParameterError ("DatasetLayout", "unknown layout");
}
}  // namespace io
}  // namespace cuefusion
