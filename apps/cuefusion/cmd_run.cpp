#include "cli.h"

#include <cuefusion/common/exceptions.h>
#include <cuefusion/common/progress.h>
#include <cuefusion/evaluation/trajectory_error.h>
#include <cuefusion/io/file_io.h>
#include <cuefusion/io/map_io.h>
#include <cuefusion/io/pose_io.h>
#include <cuefusion/io/sequence.h>
#include <cuefusion/common/label_colors.h>
#include <cuefusion/pipeline/fusion_pipeline.h>
#include <cuefusion/recognition/mask_folder_segmenter.h>
#include <cuefusion/recognition/onnx_instance_segmenter.h>

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
  std::vector<pipeline::SegmentationTimings> segmentation;  ///< per segmented frame
  std::size_t frames_without_masks = 0;
  std::size_t merges = 0;
};

/** segments.json: every segment of the map with voxels. */
nlohmann::json
segmentsJson (const std::vector<segmentation::SegmentRecord>& segments)
{
  nlohmann::json list = nlohmann::json::array ();
  for (const auto& s : segments)
  {
    nlohmann::json entry = {{"id", s.id},
                            {"voxels", s.voxels},
                            {"first_frame", s.first_frame},
                            {"last_frame", s.last_frame},
                            {"bounds", {{"min", {s.bounds.min ().x (), s.bounds.min ().y (), s.bounds.min ().z ()}},
                                        {"max", {s.bounds.max ().x (), s.bounds.max ().y (), s.bounds.max ().z ()}}}}};
    const std::string best = s.bestClass ();
    entry["class"] = best.empty () ? nlohmann::json (nullptr) : nlohmann::json (best);
    entry["score"] = best.empty () ? nlohmann::json (nullptr) : nlohmann::json (s.bestScore ());
    nlohmann::json votes = nlohmann::json::object ();
    for (const auto& [name, vote] : s.class_votes)
      votes[name] = vote.first;
    entry["class_votes"] = votes;
    list.push_back (entry);
  }
  return {{"segments", list}};
}

nlohmann::json
timingsJson (const std::vector<reconstruction::FrameReport>& reports,
             const std::vector<pipeline::SegmentationTimings>& segmentation)
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
  std::vector<double> geometry, instances, propagation, merging, update, segmentation_total;
  for (const auto& t : segmentation)
  {
    geometry.push_back (t.geometry_ms);
    instances.push_back (t.instances_ms);
    propagation.push_back (t.propagation_ms);
    merging.push_back (t.merging_ms);
    update.push_back (t.update_ms);
    segmentation_total.push_back (t.total ());
  }
  return {{"stages", {{"preprocess", timingSummary (pre)}, {"track", timingSummary (track)}, {"integrate", timingSummary (integrate)},
                      {"raycast", timingSummary (raycast)}, {"track+integrate+raycast", timingSummary (core)},
                      {"geometric segmentation", timingSummary (geometry)}, {"instance merge", timingSummary (instances)},
                      {"propagation", timingSummary (propagation)}, {"segment merging", timingSummary (merging)},
                      {"label update", timingSummary (update)}, {"segmentation", timingSummary (segmentation_total)}}},
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
  std::string masks, mode;
  std::size_t save_every = 0;
  recognition::OnnxSegmenterConfig onnx;
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
    ("save-volume", po::bool_switch (&save_volume), "also write the TSDF volume (volume.tsdf)")
    ("mode", po::value (&mode), "fused (geometry grouped by instance masks; the default with --masks/--model), geometry, or masks")
    ("masks", po::value (&masks), "folder of per-frame 16-bit instance-id PNGs (+ JSON), matched by frame name or index")
    ("model", po::value (&onnx.model_path), "YOLO-seg ONNX model run on each colour frame (OpenCV DNN, CPU)")
    ("classes", po::value (&onnx.classes_path), "class names of --model (default data/classes/coco.names)")
    ("input-size", po::value (&onnx.input_size)->default_value (onnx.input_size), "network input size of --model (px)")
    ("score-threshold", po::value (&onnx.score_threshold)->default_value (onnx.score_threshold), "--model detections below are dropped")
    ("save-every", po::value (&save_every)->default_value (0), "every K-th frame, write the map's labels seen from the camera to labels/FRAME.png (0 = never)");
  po::positional_options_description positional;
  positional.add ("sequence", 1);
  po::variables_map vm;
  if (!parseCommandLine ("run", "SEQUENCE --out DIR [options]", args, options, positional, vm))
    return 0;

  pipeline::FusionPipelineConfig pipeline_config;
  reconstruction::DenseReconstructionConfig& config = pipeline_config.reconstruction;
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

  pipeline_config.mode = chooseSegmentationMode (mode, masks, onnx.model_path);
  std::unique_ptr<recognition::InstanceSegmenter> mask_source;
  if (!masks.empty ())
    mask_source = std::make_unique<recognition::MaskFolderSegmenter> (masks);
  else if (!onnx.model_path.empty ())
    mask_source = std::make_unique<recognition::OnnxInstanceSegmenter> (onnx);

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

  pipeline::FusionPipeline fusion (pipeline_config);
  if (save_every > 0)
  {
    fs::create_directories (fs::path (out) / "labels", ec);
    if (ec)
      throw Error ((fs::path (out) / "labels").string (), "cannot create folder: " + ec.message ());
  }
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
      std::vector<Instance> instances;
      bool have_masks = false;
      if (mask_source && pipeline_config.mode != pipeline::SegmentationMode::Geometry)
      {
        have_masks = mask_source->segment (*frame, instances);
        if (!have_masks && result.frames_without_masks++ == 0)
          std::cerr << "cuefusion run: no masks for frame " << frame->index << " (nor, maybe, for later frames): "
                    << "geometry only there\n";
      }
      const pipeline::PipelineFrameReport full = fusion.process (*frame, have_masks ? &instances : nullptr);
      reconstruction::FrameReport report = full.reconstruction;
      if (full.segmented)
      {
        result.segmentation.push_back (full.segmentation);
        result.merges += full.merges;
        if (save_every > 0 && frame->index % save_every == 0)
        {
          std::ostringstream name;
          name << std::setw (6) << std::setfill ('0') << frame->index << ".png";
          io::writeImageAtomic ((fs::path (out) / "labels" / name.str ()).string (), colorizeLabels (fusion.modelLabels ()));
        }
      }
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
  const reconstruction::TSDFVolume& volume = fusion.reconstruction ().volume ();
  const pcl::PointCloud<pcl::PointXYZRGBL>::Ptr map_cloud = fusion.labelledCloud ();
  const pcl::PointCloud<pcl::PointXYZRGBL>& map = *map_cloud;
  io::saveMapPCD ((dir / "map.pcd").string (), map);
  const pcl::PolygonMesh mesh = fusion.labelledMesh (true);
  io::saveMeshPLY ((dir / "mesh.ply").string (), mesh);
  const std::vector<segmentation::SegmentRecord> segments = fusion.segments ();
  io::writeTextAtomic ((dir / "segments.json").string (), segmentsJson (segments).dump (1) + "\n");
  io::writeTumTrajectory ((dir / "trajectory.txt").string (), result.trajectory);
  if (!result.reference.empty ())  // for evaluating the estimate with any TUM tool
    io::writeTumTrajectory ((dir / "reference_trajectory.txt").string (), result.reference);
  if (save_volume)
    volume.save ((dir / "volume.tsdf").string ());

  nlohmann::json tracking;
  nlohmann::json lost = nlohmann::json::array ();
  for (const auto& r : result.reports)
    if (!r.tracked)
      lost.push_back ({{"index", r.index}, {"timestamp", r.timestamp}, {"reason", r.failure}});
  tracking["frames"] = result.reports.size ();
  tracking["tracked"] = result.trajectory.size ();
  tracking["lost"] = lost;
  tracking["mode"] = use_gt_poses ? "reference poses" : "frame-to-model ICP";
  tracking["segmentation"] = {{"mode", pipeline::segmentationModeName (pipeline_config.mode)},
                              {"mask_source", mask_source ? mask_source->name () : std::string ()},
                              {"frames_without_masks", result.frames_without_masks},
                              {"merges", result.merges}};
  tracking["volume"] = {{"blocks", volume.blockCount ()}, {"bytes", volume.memoryUsage ()},
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
  io::writeTextAtomic ((dir / "timings.json").string (), timingsJson (result.reports, result.segmentation).dump (2) + "\n");

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
            << "  segments:   " << (dir / "segments.json").string () << " (" << segments.size () << " segments, "
            << std::count_if (segments.begin (), segments.end (), [] (const segmentation::SegmentRecord& r) {
                 return !r.bestClass ().empty ();
               })
            << " with a class; mode " << pipeline::segmentationModeName (pipeline_config.mode) << ", " << result.merges
            << " merges)\n"
            << "  volume:     " << volume.blockCount () << " blocks, "
            << volume.memoryUsage () / (1024 * 1024) << " MiB\n";
  return 0;
}
}  // namespace cli
}  // namespace cuefusion
