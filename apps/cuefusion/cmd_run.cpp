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
#include <cuefusion/recognition/asynchronous_segmenter.h>
#include <cuefusion/recognition/mask_folder_segmenter.h>
#include <cuefusion/recognition/onnx_instance_segmenter.h>
#include <cuefusion/visualization/frame_view.h>
#include <cuefusion/visualization/live_viewer.h>

#include <opencv2/videoio.hpp>

#include <boost/filesystem.hpp>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <csignal>
#include <iomanip>
#include <iostream>
#include <mutex>
#include <sys/resource.h>
#include <thread>

namespace fs = boost::filesystem;

namespace cuefusion
{
namespace cli
{
namespace
{
/** SIGINT and SIGTERM: the first stops the run after its frame (the outputs are still
  * written), the second abandons writing (the folder's previous outputs stay as they
  * were), and the handlers then return to the default, so a third ends the process. */
std::atomic<int> g_signals{0};

extern "C" void
onInterrupt (int)
{
  if (++g_signals >= 2)
  {
    std::signal (SIGINT, SIG_DFL);
    std::signal (SIGTERM, SIG_DFL);
  }
}

class InterruptHandlers
{
public:
  InterruptHandlers ()
  {
    g_signals = 0;
    struct sigaction action{};
    action.sa_handler = onInterrupt;
    sigemptyset (&action.sa_mask);
    sigaction (SIGINT, &action, &previous_int_);
    sigaction (SIGTERM, &action, &previous_term_);
  }
  ~InterruptHandlers ()
  {
    sigaction (SIGINT, &previous_int_, nullptr);
    sigaction (SIGTERM, &previous_term_, nullptr);
  }
  static bool
  interrupted ()
  {
    return g_signals > 0;
  }
  static bool
  interruptedTwice ()
  {
    return g_signals > 1;
  }

private:
  struct sigaction previous_int_, previous_term_;
};

/** What `run` writes into --out (outputs.json, written last, marks a complete set). */
const std::vector<std::string> kRunOutputs = {"map.pcd",        "mesh.ply",      "segments.json",
                                              "trajectory.txt", "reference_trajectory.txt",
                                              "volume.tsdf",    "volume.keyframes", "tracking.json",
                                              "timings.json",   "labels",           "outputs.json"};

struct RunOutputs
{
  io::Trajectory trajectory;            ///< accepted poses
  io::Trajectory reference;             ///< the sequence's own poses, where it has them
  std::vector<reconstruction::FrameReport> reports;
  std::vector<pipeline::SegmentationTimings> segmentation;  ///< per segmented frame
  std::vector<std::size_t> volume_bytes;  ///< after each frame: memory growth over the run
  std::vector<double> loop_ms;            ///< per segmented frame: every stage, the mask source excluded
  std::size_t frames_without_masks = 0;
  std::size_t merges = 0;
};

/** Peak resident memory of this process so far, MiB (Linux reports ru_maxrss in KiB). */
double
peakMemoryMiB ()
{
  rusage usage{};
  getrusage (RUSAGE_SELF, &usage);
  return static_cast<double> (usage.ru_maxrss) / 1024.0;
}

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
                            {"frames_seen", s.frames_seen},
                            {"loaded", s.loaded},
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

/** --video: frames go to a temporary file next to the target, renamed into place when the
  * run ends well (a failed run leaves no half-written video). The container follows the
  * extension: .avi → Motion-JPEG (always available in OpenCV), .mp4 → MPEG-4 part 2. */
class VideoOutput
{
public:
  VideoOutput (const std::string& path, double fps) : path_ (path), fps_ (fps)
  {
    const std::string ext = fs::path (path).extension ().string ();
    if (ext == ".avi")
      fourcc_ = cv::VideoWriter::fourcc ('M', 'J', 'P', 'G');
    else if (ext == ".mp4")
      fourcc_ = cv::VideoWriter::fourcc ('m', 'p', '4', 'v');
    else
      throw ParameterError ("--video", "the file must end in .avi or .mp4, not '" + ext + "'");
    const fs::path target (path);
    boost::system::error_code ec;
    const fs::file_status status = fs::status (target, ec);
    if (fs::exists (status) && !fs::is_regular_file (status))  // renaming over it would replace a device or folder
      throw Error (path, "exists and is not a regular file; refusing to replace it");
    temporary_ = (target.parent_path () / fs::unique_path ("." + target.stem ().string () + ".tmp-%%%%%%" + ext)).string ();
  }
  ~VideoOutput ()
  {
    if (writer_.isOpened ())
      writer_.release ();
    if (!finished_)
    {
      boost::system::error_code ec;
      fs::remove (temporary_, ec);
    }
  }
  void write (const cv::Mat& image)
  {
    if (!writer_.isOpened ())
    {
      if (!writer_.open (temporary_, fourcc_, fps_, image.size ()))
        throw Error (path_, "OpenCV cannot write this video format here");
      size_ = image.size ();
    }
    if (image.size () != size_)
      throw Error (path_, "frame size changed during the run");
    writer_.write (image);
  }
  void finish ()
  {
    if (!writer_.isOpened ())
      return;
    writer_.release ();
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
};

/** The map's labels seen from the camera as a 16-bit id PNG (for `cuefusion eval`). */
cv::Mat
labelsAs16Bit (const cv::Mat& labels, const std::string& path)
{
  double max_label = 0.0;
  cv::minMaxLoc (labels, nullptr, &max_label);
  if (max_label > 65535.0)
    throw Error (path, "segment label " + std::to_string (static_cast<long long> (max_label)) + " does not fit a 16-bit PNG");
  cv::Mat out;
  labels.convertTo (out, CV_16U);
  return out;
}

nlohmann::json
timingsJson (const std::vector<reconstruction::FrameReport>& reports,
             const std::vector<pipeline::SegmentationTimings>& segmentation, const std::vector<std::size_t>& volume_bytes,
             const std::vector<double>& loop_ms)
{
  std::vector<double> pre, track, integrate, raycast, core, relocalise;
  nlohmann::json frames = nlohmann::json::array ();
  for (std::size_t k = 0; k < reports.size (); ++k)
  {
    const auto& r = reports[k];
    const auto& t = r.timings;
    frames.push_back ({{"index", r.index}, {"preprocess_ms", t.preprocess_ms}, {"track_ms", t.track_ms},
                       {"integrate_ms", t.integrate_ms}, {"raycast_ms", t.raycast_ms}, {"relocalise_ms", t.relocalise_ms},
                       {"volume_mib", k < volume_bytes.size () ? static_cast<double> (volume_bytes[k]) / (1024.0 * 1024.0) : 0.0}});
    if (t.relocalise_ms > 0.0)  // frames whose tracking failed, relocalised or not
      relocalise.push_back (t.relocalise_ms);
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
                      {"relocalise (lost frames only)", timingSummary (relocalise)},
                      {"geometric segmentation", timingSummary (geometry)}, {"instance merge", timingSummary (instances)},
                      {"propagation", timingSummary (propagation)}, {"segment merging", timingSummary (merging)},
                      {"label update", timingSummary (update)}, {"segmentation", timingSummary (segmentation_total)},
                      {"whole loop", timingSummary (loop_ms)}}},
          {"peak_memory_mib", peakMemoryMiB ()},
          {"frames", frames}};
}
}  // namespace

/** --load-volume: \a path and the .keyframes beside it continued by \a fusion. --voxel,
  * --truncation and --max-depth are the volume's; given with other values they are refused. */
void
continueSavedVolume (const std::string& path, const po::variables_map& vm, const reconstruction::KeyframeDatabaseConfig& keyframes,
                     pipeline::FusionPipeline& fusion)
{
  reconstruction::TSDFVolume volume = reconstruction::TSDFVolume::load (path);
  const reconstruction::TSDFVolumeConfig& saved = volume.getConfig ();
  const std::pair<const char*, double> fixed[] = {{"voxel", saved.voxel_size},
                                                  {"truncation", saved.truncation_voxels},
                                                  {"max-depth", saved.max_depth}};
  for (const auto& [option, value] : fixed)
    if (given (vm, option) && std::abs (vm[option].as<double> () - value) > 1e-9 * std::max (1.0, value))
    {
      std::ostringstream why;
      why << "the loaded volume " << path << " has " << value << "; leave it out or give the same";
      throw ParameterError (std::string ("--") + option, why.str ());
    }
  const std::string keyframes_path = fs::path (path).replace_extension (".keyframes").string ();
  boost::system::error_code ec;
  if (fs::exists (keyframes_path, ec))
    fusion.continueFrom (std::move (volume), reconstruction::KeyframeDatabase::load (keyframes_path));
  else
  {
    std::cerr << "cuefusion run: no " << keyframes_path << " beside the volume: the first frame can be placed only at "
              << "the sequence's own pose\n";
    fusion.continueFrom (std::move (volume), reconstruction::KeyframeDatabase (keyframes));
  }
}

void
addRunOptions (po::options_description& options, RunSettings& s)
{
  options.add_options ()
    ("frames", po::value (&s.frames)->default_value (s.frames), "process at most N frames (0 = all)")
    ("format", po::value (&s.format)->default_value (s.format), "auto, tum, redwood, 7scenes, scannet, openni2")
    ("intrinsics", po::value (&s.intrinsics), "intrinsics file overriding the sequence's own")
    ("voxel", po::value (&s.voxel)->default_value (s.voxel), "TSDF voxel size in metres")
    ("truncation", po::value (&s.truncation)->default_value (s.truncation), "TSDF truncation distance in voxels")
    ("max-depth", po::value (&s.max_depth)->default_value (s.max_depth), "ignore depth beyond this (metres)")
    ("use-gt-poses", po::bool_switch (&s.use_gt_poses), "integrate with the sequence's own poses instead of tracking")
    ("no-motion-model", po::bool_switch (&s.no_motion_model), "tracking: start ICP at the last pose instead of the constant-velocity prediction")
    ("no-noise-weighting", po::bool_switch (&s.no_noise_weighting), "tracking: every ICP term counts the same, instead of by the inverse depth-noise variance")
    ("hole-refresh", po::value (&s.hole_refresh)->default_value (s.hole_refresh), "raycast: rays behind depth holes that found no surface are searched again every N frames (1 = every frame)")
    ("save-volume", po::bool_switch (&s.save_volume), "also write the TSDF volume (volume.tsdf, labels as map.pcd's) and the relocalisation keyframes (volume.keyframes)")
    ("load-volume", po::value (&s.load_volume), "continue a saved volume.tsdf (and the volume.keyframes beside it): the first frame is relocalised in it, its objects are kept")
    ("mode", po::value (&s.mode), "fused (geometry grouped by instance masks; the default with --masks/--model), geometry, or masks")
    ("masks", po::value (&s.masks), "folder of per-frame 16-bit instance-id PNGs (+ JSON), matched by frame name or index")
    ("model", po::value (&s.onnx.model_path), "instance masks from an ONNX model (OpenCV DNN, CPU): cuefusion's depth network "
     "data/models/xyz_instances.onnx, or a YOLO-seg export run on the colour image")
    ("classes", po::value (&s.onnx.classes_path), "class names of --model (default data/classes/coco.names)")
    ("input-size", po::value (&s.onnx.input_size)->default_value (s.onnx.input_size), "network input size of --model (px)")
    ("score-threshold", po::value (&s.onnx.score_threshold)->default_value (s.onnx.score_threshold), "--model detections below are dropped")
    ("boundary-threshold", po::value (&s.onnx.boundary_threshold)->default_value (s.onnx.boundary_threshold),
     "--model of the xyz layout: instances are cut where the boundary probability reaches this")
    ("async-masks", po::bool_switch (&s.async_masks), "run the mask source on its own thread and use its newest finished masks (always on for live cameras; offline runs are otherwise frame-exact)")
    ("save-every", po::value (&s.save_every)->default_value (s.save_every), "every K-th frame, write the map's segment ids seen from the camera to labels/INDEX.png (16-bit; 0 = never)")
    ("render", po::value (&s.render_dir), "write per-frame PNGs to DIR: input colour, depth and the map's segments seen from the camera")
    ("video", po::value (&s.video_path), "the same panels as a video (.avi Motion-JPEG or .mp4)")
    ("view", po::bool_switch (&s.view), "show the map growing in a PCLVisualizer window (needs a display)")
    ("view-screenshot", po::value (&s.screenshot), "with --view: save the window as PNG when the run ends and close it");
}

void
checkRunSettings (const RunSettings& s)
{
  if (s.frames < 0)
    throw ParameterError ("--frames", "must not be negative (0 = all frames), got " + std::to_string (s.frames));
  if (s.save_every < 0)
    throw ParameterError ("--save-every", "must not be negative (0 = never), got " + std::to_string (s.save_every));
  if (!s.screenshot.empty () && !s.view)
    throw UsageError ("--view-screenshot needs --view");
  io::parseSequenceFormat (s.format);
  // The library's own checks, named by field (main() translates them into the options).
  runPipelineConfig (s).validate ();
  if (!s.onnx.model_path.empty ())
    s.onnx.validate ();  // the segmenter checks it again when it is built
}

pipeline::FusionPipelineConfig
runPipelineConfig (const RunSettings& s)
{
  pipeline::FusionPipelineConfig pipeline_config;
  reconstruction::DenseReconstructionConfig& config = pipeline_config.reconstruction;
  config.volume.voxel_size = s.voxel;
  config.volume.truncation_voxels = s.truncation;
  config.volume.max_depth = s.max_depth;
  config.preprocessing.max_depth = s.max_depth;
  config.use_reference_poses = s.use_gt_poses;
  config.hole_refresh_period = s.hole_refresh;
  config.motion_model = !s.no_motion_model;
  config.tracking.icp.noise_weighting = !s.no_noise_weighting;
  pipeline_config.mode = chooseSegmentationMode (s.mode, s.masks, s.onnx.model_path);
  return pipeline_config;
}

int
runRun (const std::vector<std::string>& args)
{
  RunSettings settings;
  po::options_description options ("options");
  options.add_options ()
    ("sequence", po::value (&settings.source)->required (), "dataset folder, openni2[:DEVICE] or .oni file")
    ("out", po::value (&settings.out)->required (), "output folder");
  addRunOptions (options, settings);
  po::positional_options_description positional;
  positional.add ("sequence", 1);
  po::variables_map vm;
  if (!parseCommandLine ("run", "SEQUENCE --out DIR [options]", args, options, positional, vm))
    return 0;
  checkRunSettings (settings);
  // The steps below name the settings as they were named before RunSettings gathered them.
  const RunSettings& s = settings;
  const std::string &source = s.source, &out = s.out, &format = s.format, &intrinsics = s.intrinsics;
  const bool use_gt_poses = s.use_gt_poses, save_volume = s.save_volume, view = s.view, async_masks = s.async_masks;
  const std::string &masks = s.masks, &render_dir = s.render_dir, &video_path = s.video_path, &screenshot = s.screenshot;
  const recognition::OnnxInstanceSegmenterConfig& onnx = s.onnx;
  const std::size_t max_frames = static_cast<std::size_t> (s.frames), save_every = static_cast<std::size_t> (s.save_every);

  const pipeline::FusionPipelineConfig pipeline_config = runPipelineConfig (s);
  std::shared_ptr<recognition::InstanceSegmenter> mask_source;
  if (!masks.empty ())
    mask_source = std::make_shared<recognition::MaskFolderSegmenter> (masks);
  else if (!onnx.model_path.empty ())
    mask_source = std::make_shared<recognition::OnnxInstanceSegmenter> (onnx);

  io::SequenceOptions opts;
  opts.format = io::parseSequenceFormat (format);
  opts.intrinsics_path = intrinsics;
  const io::RGBDGrabber::Ptr grabber = io::openSequence (source, opts);
  const auto dataset = std::dynamic_pointer_cast<io::DatasetGrabber> (grabber);
  if (use_gt_poses && (!dataset || !dataset->hasPoses ()))
    throw ParameterError ("--use-gt-poses", source + " has no reference poses");
  if (dataset)
    dataset->setFrameLimit (max_frames);
  // A live camera does not wait for the network (thesis §6.1).
  const bool asynchronous_masks = mask_source && (async_masks || !dataset);
  if (asynchronous_masks)  // the first frames go without masks until the first finish
    mask_source = std::make_shared<recognition::AsynchronousSegmenter> (mask_source);

  // Everything goes to a staging folder first and replaces the previous run's set as a
  // whole at the end (io::OutputSet): an error or a second signal leaves it untouched.
  io::OutputSet outputs (out, kRunOutputs, "outputs.json");
  pipeline::FusionPipeline fusion (pipeline_config);
  if (!s.load_volume.empty ())
    continueSavedVolume (s.load_volume, vm, pipeline_config.reconstruction.keyframes, fusion);
  boost::system::error_code ec;
  if (!render_dir.empty ())
  {
    fs::create_directories (render_dir, ec);
    if (ec || !fs::is_directory (render_dir))
      throw Error (render_dir, "cannot create folder" + (ec ? ": " + ec.message () : std::string ()));
  }
  std::unique_ptr<VideoOutput> video;
  if (!video_path.empty ())
    video = std::make_unique<VideoOutput> (video_path, dataset && dataset->getFramesPerSecond () > 0.f ? dataset->getFramesPerSecond () : 30.0);
  // The window belongs to this (the main) thread; processing moves to a worker below.
  std::unique_ptr<visualization::LiveViewer> viewer;
  if (view)
    viewer = std::make_unique<visualization::LiveViewer> ("cuefusion run: " + source);
  auto last_view_post = std::chrono::steady_clock::now () - std::chrono::seconds (10);
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
        if (!have_masks && result.frames_without_masks++ == 0 && !asynchronous_masks)
          std::cerr << "cuefusion run: no masks for frame " << frame->index << " (nor, maybe, for later frames): "
                    << "geometry only there\n";
      }
      const pipeline::PipelineFrameReport full = fusion.process (*frame, have_masks ? &instances : nullptr);
      reconstruction::FrameReport report = full.reconstruction;
      if (full.segmented)
      {
        result.segmentation.push_back (full.segmentation);
        const reconstruction::StageTimings& t = full.reconstruction.timings;
        result.loop_ms.push_back (t.preprocess_ms + t.track_ms + t.integrate_ms + t.raycast_ms + full.segmentation.total ());
        result.merges += full.merges;
        std::ostringstream name;
        name << std::setw (6) << std::setfill ('0') << frame->index << ".png";
        const bool save_labels = save_every > 0 && frame->index % save_every == 0;
        if (save_labels || !render_dir.empty () || video)
        {
          const cv::Mat labels = fusion.modelLabels ();
          if (save_labels)
          {
            const std::string path = outputs.stagingPath ("labels/" + name.str ());
            io::writeImageAtomic (path, labelsAs16Bit (labels, outputs.finalPath ("labels/" + name.str ())));
          }
          if (!render_dir.empty () || video)
          {
            const cv::Mat panel = visualization::composeFrameView (*frame, labels);
            if (!render_dir.empty ())
              io::writeImageAtomic ((fs::path (render_dir) / name.str ()).string (), panel);
            if (video)
              video->write (panel);
          }
        }
      }
      if (viewer && report.tracked)
      {
        // The map is re-extracted at most twice a second: it grows with the scene.
        const auto now = std::chrono::steady_clock::now ();
        viewer->postFrame (frame->camera, report.pose, toPointCloud (*frame));
        if (now - last_view_post > std::chrono::milliseconds (500))
        {
          viewer->postMap (fusion.labelledCloud ());
          last_view_post = now;
        }
      }
      if (report.tracked)
        result.trajectory.push_back ({frame->timestamp, report.pose});
      if (frame->pose)
        result.reference.push_back ({frame->timestamp, *frame->pose});
      result.reports.push_back (std::move (report));
      result.volume_bytes.push_back (fusion.reconstruction ().volume ().memoryUsage ());
      progress.update (result.reports.size ());
    }
    catch (const std::exception& e)  // a live camera's thread must not die with an exception
    {
      callback_error = describeException (e);
    }
  };
  const boost::signals2::connection connection = grabber->registerCallback (on_frame);
  const InterruptHandlers interrupt_handlers;
  const auto process = [&] {
    grabber->start ();
    if (dataset)
    {
      while (!InterruptHandlers::interrupted () && dataset->trigger ())
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
        if (InterruptHandlers::interrupted () || !grabber->isRunning () || !callback_error.empty () ||
            (max_frames && result.reports.size () >= max_frames))
          break;
      }
    }
    grabber->stop ();
  };
  if (viewer)
  {
    std::atomic<bool> done{false};
    std::thread worker ([&] {
      try
      {
        process ();
      }
      catch (const std::exception& e)
      {
        const std::lock_guard<std::mutex> lock (mutex);
        callback_error = describeException (e);
      }
      done = true;
    });
    bool window_open = true;
    while (!done)
      if (window_open && !viewer->spinOnce (30))
      {
        window_open = false;  // closing the window stops the run, which still writes its map
        int none = 0;  // as one signal: stop, then write everything
        g_signals.compare_exchange_strong (none, 1);
      }
      else if (!window_open)
        std::this_thread::sleep_for (std::chrono::milliseconds (30));
    worker.join ();
    if (window_open)
    {
      viewer->postMap (fusion.labelledCloud ());
      viewer->spinOnce (30);
      if (!screenshot.empty ())
        viewer->saveScreenshot (screenshot);
      else
      {
        std::cerr << "cuefusion run: done; close the window to write the outputs\n";
        viewer->setFollowCamera (false);  // the mouse has the view now
        while (viewer->spinOnce (30))
        {
        }
      }
    }
    viewer.reset ();
  }
  else
    process ();
  connection.disconnect ();
  progress.finish ();
  if (!callback_error.empty ())
    throw Error (source, callback_error);
  if (!grabber->lastError ().empty ())
    throw Error (source, grabber->lastError ());
  if (result.reports.empty ())
    throw Error (source, "no frame was processed");
  const double seconds = std::chrono::duration<double> (std::chrono::steady_clock::now () - t0).count ();

  const fs::path dir (out);
  // A second signal while writing abandons the set; checked between the files.
  const auto staged = [&] (const std::string& name) {
    if (InterruptHandlers::interruptedTwice ())
      throw Error (out, "interrupted again while writing the outputs: nothing written, the folder's previous outputs are unchanged");
    return outputs.stagingPath (name);
  };
  const reconstruction::TSDFVolume& volume = fusion.reconstruction ().volume ();
  const pcl::PointCloud<pcl::PointXYZRGBL>::Ptr map_cloud = fusion.labelledCloud ();
  const pcl::PointCloud<pcl::PointXYZRGBL>& map = *map_cloud;
  io::saveMapPCD (staged ("map.pcd"), map);
  const pcl::PolygonMesh mesh = fusion.labelledMesh (true);
  io::saveMeshPLY (staged ("mesh.ply"), mesh);
  const std::vector<segmentation::SegmentRecord> segments = fusion.segments ();
  io::writeTextAtomic (staged ("segments.json"), segmentsJson (segments).dump (1) + "\n");
  io::writeTumTrajectory (staged ("trajectory.txt"), result.trajectory);
  if (!result.reference.empty ())  // for evaluating the estimate with any TUM tool
    io::writeTumTrajectory (staged ("reference_trajectory.txt"), result.reference);
  if (save_volume)
    fusion.saveVolume (staged ("volume.tsdf"), staged ("volume.keyframes"));

  nlohmann::json tracking;
  nlohmann::json lost = nlohmann::json::array ();
  for (const auto& r : result.reports)
    if (!r.tracked)
      lost.push_back ({{"index", r.index}, {"timestamp", r.timestamp}, {"reason", r.failure}});
  nlohmann::json relocalised = nlohmann::json::array ();
  for (const auto& r : result.reports)
    if (r.relocalised)
      relocalised.push_back ({{"index", r.index}, {"timestamp", r.timestamp}, {"from", r.relocalised_from},
                              {"ms", r.timings.relocalise_ms}});
  tracking["frames"] = result.reports.size ();
  tracking["tracked"] = result.trajectory.size ();
  tracking["lost"] = lost;
  tracking["relocalised"] = relocalised;
  tracking["mode"] = use_gt_poses ? "reference poses" : "frame-to-model ICP";
  tracking["segmentation"] = {{"mode", pipeline::segmentationModeName (pipeline_config.mode)},
                              {"mask_source", mask_source ? mask_source->name () : std::string ()},
                              {"frames_without_masks", result.frames_without_masks},
                              {"merges", result.merges}};
  tracking["volume"] = {{"blocks", volume.blockCount ()}, {"bytes", volume.memoryUsage ()},
                        {"voxel_size", volume.getConfig ().voxel_size}, {"truncation_voxels", volume.getConfig ().truncation_voxels}};
  if (!s.load_volume.empty ())
    tracking["continued_from"] = s.load_volume;
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
  io::writeTextAtomic (staged ("tracking.json"), tracking.dump (2) + "\n");
  io::writeTextAtomic (staged ("timings.json"), timingsJson (result.reports, result.segmentation, result.volume_bytes, result.loop_ms).dump (2) + "\n");
  nlohmann::json files = nlohmann::json::array ();
  for (const std::string& name : kRunOutputs)
    if (fs::exists (fs::path (outputs.stagingPath (name))))
      files.push_back (name);
  const nlohmann::json manifest = {{"command", "run"},
                                   {"sequence", source},
                                   {"frames", result.reports.size ()},
                                   {"seconds", seconds},  // processing, opening the sequence to the last frame
                                   {"complete", true},
                                   // a recorded sequence cut short by a signal or a closed window
                                   {"stopped_early", dataset != nullptr && InterruptHandlers::interrupted ()},
                                   {"files", files}};
  io::writeTextAtomic (staged ("outputs.json"), manifest.dump (2) + "\n");
  if (video)
    video->finish ();
  outputs.commit ();

  std::cout << "processed " << result.reports.size () << " frames of " << source << " (" << grabber->formatName ()
            << ") in " << std::fixed << std::setprecision (2) << seconds << " s; " << result.trajectory.size ()
            << " fused" << std::defaultfloat;
  if (!lost.empty ())
    std::cout << ", " << lost.size () << " lost (tracking.json lists them)";
  if (!relocalised.empty ())
    std::cout << ", " << relocalised.size () << " relocalised";
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
