#include "cli.h"

#include <cuefusion/common/exceptions.h>
#include <cuefusion/common/progress.h>
#include <cuefusion/io/map_io.h>
#include <cuefusion/io/pose_io.h>
#include <cuefusion/io/sequence.h>

#include <boost/filesystem.hpp>
#include <pcl/common/transforms.h>
#include <pcl/filters/voxel_grid.h>

#include <chrono>
#include <iomanip>
#include <iostream>

namespace fs = boost::filesystem;

namespace cuefusion
{
namespace cli
{
namespace
{
using Cloud = pcl::PointCloud<pcl::PointXYZRGBA>;

Cloud::Ptr
downsample (const Cloud::ConstPtr& cloud, float voxel)
{
  auto out = pcl::make_shared<Cloud> ();
  pcl::VoxelGrid<pcl::PointXYZRGBA> grid;
  grid.setInputCloud (cloud);
  grid.setLeafSize (voxel, voxel, voxel);
  grid.filter (*out);
  return out;
}
}  // namespace

int
runRun (const std::vector<std::string>& args)
{
  std::string source, out, format, intrinsics;
  std::size_t max_frames = 0;
  float voxel = 0.01f;
  po::options_description options ("options");
  options.add_options ()
    ("sequence", po::value (&source)->required (), "dataset folder, openni2[:DEVICE] or .oni file")
    ("out", po::value (&out)->required (), "output folder")
    ("frames", po::value (&max_frames)->default_value (0), "process at most N frames (0 = all)")
    ("format", po::value (&format)->default_value ("auto"), "auto, tum, redwood, 7scenes, scannet, openni2")
    ("intrinsics", po::value (&intrinsics), "intrinsics file overriding the sequence's own")
    ("voxel", po::value (&voxel)->default_value (voxel), "map resolution in metres");
  po::positional_options_description positional;
  positional.add ("sequence", 1);
  po::variables_map vm;
  if (!parseCommandLine ("run", "SEQUENCE --out DIR [options]", args, options, positional, vm))
    return 0;
  if (!(voxel >= 0.001f && voxel <= 1.f))
    throw ParameterError ("--voxel", "must lie in [0.001, 1] metres");

  io::SequenceOptions opts;
  opts.format = io::parseSequenceFormat (format);
  opts.intrinsics_path = intrinsics;
  const io::RGBDGrabber::Ptr grabber = io::openSequence (source, opts);
  const auto dataset = std::dynamic_pointer_cast<io::DatasetGrabber> (grabber);
  // The map is fused with the sequence's reference poses; frame-to-model tracking
  // (reconstruction module) is what lets live cameras and pose-less sequences run.
  if (!dataset)
    throw Error (source, "live sources need camera tracking, which this build does not have yet");
  if (!dataset->hasPoses ())
    throw Error (source, "has no reference poses (needed until camera tracking is available)");
  dataset->setFrameLimit (max_frames);

  boost::system::error_code ec;
  fs::create_directories (out, ec);
  if (ec || !fs::is_directory (out))
    throw Error (out, "cannot create output folder" + (ec ? ": " + ec.message () : std::string ()));

  auto map = pcl::make_shared<Cloud> ();
  io::Trajectory trajectory;
  std::size_t processed = 0, skipped = 0, since_compaction = 0;
  ProgressReporter progress ("run", dataset->size ());
  const auto t0 = std::chrono::steady_clock::now ();
  std::function<io::RGBDGrabber::sig_cb_rgbd_frame> on_frame = [&] (const RGBDFrame::ConstPtr& frame) {
    ++processed;
    progress.update (processed);
    if (!frame->pose)
    {
      ++skipped;
      return;
    }
    trajectory.push_back ({frame->timestamp, *frame->pose});
    Cloud world;
    pcl::transformPointCloud (*downsample (toPointCloud (*frame), voxel), world, frame->pose->matrix ().cast<float> ());
    *map += world;
    if (++since_compaction == 10)
    {
      map = downsample (map, voxel);
      since_compaction = 0;
    }
  };
  const boost::signals2::connection connection = dataset->registerCallback (on_frame);
  dataset->start ();
  while (dataset->trigger ())
  {
  }
  connection.disconnect ();
  progress.finish ();
  const double seconds = std::chrono::duration<double> (std::chrono::steady_clock::now () - t0).count ();
  map = downsample (map, voxel);

  pcl::PointCloud<pcl::PointXYZRGBL> labelled;
  pcl::copyPointCloud (*map, labelled);  // label 0: segmentation is not part of this build yet
  const std::string map_path = (fs::path (out) / "map.pcd").string ();
  const std::string trajectory_path = (fs::path (out) / "trajectory.txt").string ();
  io::saveMapPCD (map_path, labelled);
  io::writeTumTrajectory (trajectory_path, trajectory);

  std::cout << "processed " << processed << " frames of " << source << " (" << dataset->formatName () << ") in "
            << std::fixed << std::setprecision (2) << seconds << " s" << std::defaultfloat;
  if (skipped)
    std::cout << ", " << skipped << " without a reference pose skipped";
  std::cout << "\n"
            << "  map:        " << map_path << " (" << labelled.size () << " points, " << voxel << " m voxels)\n"
            << "  trajectory: " << trajectory_path << " (" << trajectory.size () << " poses, TUM format)\n";
  return 0;
}
}  // namespace cli
}  // namespace cuefusion
