#include "cli.h"

#include <cuefusion/common/exceptions.h>
#include <cuefusion/common/progress.h>
#include <cuefusion/evaluation/trajectory_error.h>
#include <cuefusion/io/file_io.h>
#include <cuefusion/io/map_io.h>
#include <cuefusion/io/pose_io.h>
#include <cuefusion/io/sequence.h>
#include <cuefusion/reconstruction/dense_reconstruction.h>

#include <boost/filesystem.hpp>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <csignal>
#include <iomanip>
#include <iostream>
#include <mutex>
#include <thread>

namespace fs = boost::filesystem;

namespace cuefusion
{
namespace cli
{
namespace
{
std::atomic<bool> g_interrupted{false};

extern "C" void
onInterrupt (int)
{
  g_interrupted = true;
}

struct RunOutputs
{
  io::Trajectory trajectory;            ///< accepted poses
  io::Trajectory reference;             ///< the sequence's own poses, where it has them
  std::vector<reconstruction::FrameReport> reports;
};

nlohmann::json
timingsJson (const std::vector<reconstruction::FrameReport>& reports)
{
  std::vector<double> pre, track, integrate, raycast, core;
  nlohmann::json frames = nlohmann::json::array ();
  for (const auto& r : reports)
  {
    const auto& t = r.timings;
    frames.push_back ({{"index", r.index}, {"preprocess_ms", t.preprocess_ms}, {"track_ms", t.track_ms},
                       {"integrate_ms", t.integrate_ms}, {"raycast_ms", t.raycast_ms}});
    if (!r.tracked)
      continue;
    pre.push_back (t.preprocess_ms);
    track.push_back (t.track_ms);
    integrate.push_back (t.integrate_ms);
    raycast.push_back (t.raycast_ms);
    core.push_back (t.track_ms + t.integrate_ms + t.raycast_ms);
  }
  return {{"stages", {{"preprocess", timingSummary (pre)}, {"track", timingSummary (track)}, {"integrate", timingSummary (integrate)},
                      {"raycast", timingSummary (raycast)}, {"track+integrate+raycast", timingSummary (core)}}},
          {"frames", frames}};
}
}  // namespace

int
runRun (const std::vector<std::string>& args)
{
  std::string source, out, format, intrinsics;
  std::size_t max_frames = 0;
  double voxel = 0.01, truncation = 4.0, max_depth = 5.0;
  bool use_gt_poses = false, save_volume = false;
  po::options_description options ("options");
  options.add_options ()
    ("sequence", po::value (&source)->required (), "dataset folder, openni2[:DEVICE] or .oni file")
    ("out", po::value (&out)->required (), "output folder")
    ("frames", po::value (&max_frames)->default_value (0), "process at most N frames (0 = all)")
    ("format", po::value (&format)->default_value ("auto"), "auto, tum, redwood, 7scenes, scannet, openni2")
    ("intrinsics", po::value (&intrinsics), "intrinsics file overriding the sequence's own")
    ("voxel", po::value (&voxel)->default_value (voxel), "TSDF voxel size in metres")
    ("truncation", po::value (&truncation)->default_value (truncation), "TSDF truncation distance in voxels")
    ("max-depth", po::value (&max_depth)->default_value (max_depth), "ignore depth beyond this (metres)")
    ("use-gt-poses", po::bool_switch (&use_gt_poses), "integrate with the sequence's own poses instead of tracking")
    ("save-volume", po::bool_switch (&save_volume), "also write the TSDF volume (volume.tsdf)");
  po::positional_options_description positional;
  positional.add ("sequence", 1);
  po::variables_map vm;
  if (!parseCommandLine ("run", "SEQUENCE --out DIR [options]", args, options, positional, vm))
    return 0;

  reconstruction::DenseReconstructionConfig config;
  config.volume.voxel_size = voxel;
  config.volume.truncation_voxels = truncation;
  config.volume.max_depth = max_depth;
  config.preprocessing.max_depth = max_depth;
  config.use_reference_poses = use_gt_poses;
  if (!(voxel >= 0.001 && voxel <= 1.0))
    throw ParameterError ("--voxel", "must lie in [0.001, 1] metres");
  if (!(truncation >= 1.0 && truncation <= 64.0))
    throw ParameterError ("--truncation", "must lie in [1, 64] voxels");
  if (!(max_depth > 0.2 && max_depth <= 100.0))
    throw ParameterError ("--max-depth", "must lie in (0.2, 100] metres");

  io::SequenceOptions opts;
  opts.format = io::parseSequenceFormat (format);
  opts.intrinsics_path = intrinsics;
  const io::RGBDGrabber::Ptr grabber = io::openSequence (source, opts);
  const auto dataset = std::dynamic_pointer_cast<io::DatasetGrabber> (grabber);
  if (use_gt_poses && (!dataset || !dataset->hasPoses ()))
    throw ParameterError ("--use-gt-poses", source + " has no reference poses");
  if (dataset)
    dataset->setFrameLimit (max_frames);

  boost::system::error_code ec;
  fs::create_directories (out, ec);
  if (ec || !fs::is_directory (out))
    throw Error (out, "cannot create output folder" + (ec ? ": " + ec.message () : std::string ()));

  reconstruction::DenseReconstruction fusion (config);
  RunOutputs result;
  std::mutex mutex;
  std::string callback_error;
  ProgressReporter progress ("run", dataset ? dataset->size () : 0);
  const auto t0 = std::chrono::steady_clock::now ();
  std::function<io::RGBDGrabber::sig_cb_rgbd_frame> on_frame = [&] (const RGBDFrame::ConstPtr& frame) {
    const std::lock_guard<std::mutex> lock (mutex);
    if (!callback_error.empty () || (max_frames && result.reports.size () >= max_frames))
      return;
    try
    {
      reconstruction::FrameReport report = fusion.process (*frame);
      if (report.tracked)
        result.trajectory.push_back ({frame->timestamp, report.pose});
      if (frame->pose)
        result.reference.push_back ({frame->timestamp, *frame->pose});
      result.reports.push_back (std::move (report));
      progress.update (result.reports.size ());
    }
    catch (const std::exception& e)  // a live camera's thread must not die with an exception
    {
      callback_error = e.what ();
    }
  };
  const boost::signals2::connection connection = grabber->registerCallback (on_frame);
  const auto previous_handler = std::signal (SIGINT, onInterrupt);
  grabber->start ();
  if (dataset)
  {
    while (!g_interrupted && dataset->trigger ())
    {
      const std::lock_guard<std::mutex> lock (mutex);
      if (!callback_error.empty ())
        break;
    }
  }
  else
  {
    std::cerr << "cuefusion run: reconstructing from " << source << "; Ctrl-C stops and writes the map\n";
    for (;;)
    {
      std::this_thread::sleep_for (std::chrono::milliseconds (20));
      const std::lock_guard<std::mutex> lock (mutex);
      if (g_interrupted || !grabber->isRunning () || !callback_error.empty () ||
          (max_frames && result.reports.size () >= max_frames))
        break;
    }
  }
  grabber->stop ();
  connection.disconnect ();
  std::signal (SIGINT, previous_handler);
  progress.finish ();
  if (!callback_error.empty ())
    throw Error (source, callback_error);
  if (!grabber->lastError ().empty ())
    throw Error (source, grabber->lastError ());
  if (result.reports.empty ())
    throw Error (source, "no frame was processed");
  const double seconds = std::chrono::duration<double> (std::chrono::steady_clock::now () - t0).count ();

  const fs::path dir (out);
  pcl::PointCloud<pcl::PointXYZRGBL> map;
  fusion.volume ().extractPointCloud (map);
  io::saveMapPCD ((dir / "map.pcd").string (), map);
  const pcl::PolygonMesh mesh = fusion.volume ().extractMesh ();
  io::saveMeshPLY ((dir / "mesh.ply").string (), mesh);
  io::writeTumTrajectory ((dir / "trajectory.txt").string (), result.trajectory);
  if (!result.reference.empty ())  // for evaluating the estimate with any TUM tool
    io::writeTumTrajectory ((dir / "reference_trajectory.txt").string (), result.reference);
  if (save_volume)
    fusion.volume ().save ((dir / "volume.tsdf").string ());

  nlohmann::json tracking;
  nlohmann::json lost = nlohmann::json::array ();
  for (const auto& r : result.reports)
    if (!r.tracked)
      lost.push_back ({{"index", r.index}, {"timestamp", r.timestamp}, {"reason", r.failure}});
  tracking["frames"] = result.reports.size ();
  tracking["tracked"] = result.trajectory.size ();
  tracking["lost"] = lost;
  tracking["mode"] = use_gt_poses ? "reference poses" : "frame-to-model ICP";
  tracking["volume"] = {{"blocks", fusion.volume ().blockCount ()}, {"bytes", fusion.volume ().memoryUsage ()},
                        {"voxel_size", voxel}, {"truncation_voxels", truncation}};
  std::string ate_line;
  if (!use_gt_poses && result.reference.size () >= 3 && result.trajectory.size () >= 3)
  {
    const evaluation::TrajectoryError ate = evaluation::absoluteTrajectoryError (result.trajectory, result.reference, 1e-4);
    tracking["ate"] = {{"rmse", ate.rmse}, {"mean", ate.mean}, {"median", ate.median}, {"max", ate.max}, {"pairs", ate.pairs}};
    std::ostringstream line;
    line << std::fixed << std::setprecision (4) << "  ATE RMSE:   " << ate.rmse << " m against the sequence's poses ("
         << ate.pairs << " frames)\n";
    ate_line = line.str ();
  }
  io::writeTextAtomic ((dir / "tracking.json").string (), tracking.dump (2) + "\n");
  io::writeTextAtomic ((dir / "timings.json").string (), timingsJson (result.reports).dump (2) + "\n");

  std::cout << "processed " << result.reports.size () << " frames of " << source << " (" << grabber->formatName ()
            << ") in " << std::fixed << std::setprecision (2) << seconds << " s; " << result.trajectory.size ()
            << " fused" << std::defaultfloat;
  if (!lost.empty ())
    std::cout << ", " << lost.size () << " lost (tracking.json lists them)";
  std::cout << "\n"
            << ate_line << "  map:        " << (dir / "map.pcd").string () << " (" << map.size () << " points)\n"
            << "  mesh:       " << (dir / "mesh.ply").string () << " (" << mesh.polygons.size () << " triangles)\n"
            << "  trajectory: " << (dir / "trajectory.txt").string () << " (" << result.trajectory.size ()
            << " poses, TUM format)\n"
            << "  volume:     " << fusion.volume ().blockCount () << " blocks, "
            << fusion.volume ().memoryUsage () / (1024 * 1024) << " MiB\n";
  return 0;
}
}  // namespace cli
}  // namespace cuefusion
