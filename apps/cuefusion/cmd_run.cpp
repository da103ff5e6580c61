// SPDX-License-Identifier: BSD-3-Clause
#include "cli.h"
#include "process.h"
#include "run_display.h"

#include <cuefusion/common/data_directory.h>
#include <cuefusion/common/exceptions.h>
#include <cuefusion/common/progress.h>
#include <cuefusion/evaluation/trajectory_error.h>
#include <cuefusion/io/file_io.h>
#include <cuefusion/io/map_io.h>
#include <cuefusion/io/mesh_io.h>
#include <cuefusion/io/pose_io.h>
#include <cuefusion/io/sequence.h>
#include <cuefusion/common/label_colors.h>
#include <cuefusion/pipeline/fusion_pipeline.h>
#include <cuefusion/pipeline/run_files.h>
#include <cuefusion/pipeline/settings.h>
#include <cuefusion/recognition/settings.h>
#include <cuefusion/segmentation/fragmentation.h>
#include <cuefusion/segmentation/object_geometry.h>
#include <cuefusion/segmentation/segments_file.h>
#include <cuefusion/recognition/asynchronous_segmenter.h>
#include <cuefusion/recognition/frame_prefetcher.h>
#include <cuefusion/recognition/mask_folder_segmenter.h>
#include <cuefusion/recognition/onnx_instance_segmenter.h>
#include <cuefusion/recognition/periodic_segmenter.h>
#include <cuefusion/visualization/frame_view.h>

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
#if defined(__GLIBC__)
#include <malloc.h>
#endif
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
  InterruptHandlers () : handlers_ ((g_signals = 0, onInterrupt)) {}
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
  StopSignalHandlers handlers_;
};

/** What `run` writes into --out (outputs.json, written last, marks a complete set). */
const std::vector<std::string> kRunOutputs = {"map.pcd",        "mesh.ply",      "segments.json",
                                              "trajectory.txt", "reference_trajectory.txt",
                                              "volume.tsdf",    "volume.labels",    "volume.keyframes", "tracking.json",
                                              "timings.json",   "labels",           "objects",          "outputs.json"};

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

}  // namespace

/** --load-volume: \a path and the .labels and .keyframes beside it continued by \a fusion. --voxel,
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
  segmentation::VoxelLabelLayer labels =
      segmentation::VoxelLabelLayer::load (fs::path (path).replace_extension (".labels").string (), volume);
  const std::string keyframes_path = fs::path (path).replace_extension (".keyframes").string ();
  boost::system::error_code ec;
  if (fs::exists (keyframes_path, ec))
  {
    reconstruction::KeyframeDatabase database = reconstruction::KeyframeDatabase::load (keyframes_path, volume);
    fusion.continueFrom (std::move (volume), std::move (labels), std::move (database));
  }
  else
  {
    std::cerr << "cuefusion run: no " << keyframes_path << " beside the volume: the first frame can be placed only at "
              << "the sequence's own pose\n";
    fusion.continueFrom (std::move (volume), std::move (labels), reconstruction::KeyframeDatabase (keyframes));
  }
}


namespace
{
/** One `cuefusion run`: the sequence, the mask source, the pipeline and what the frames
  * gave, from set-up (the constructor) through the frames (onFrame, called by the
  * grabber) to the outputs (writeOutputs) and the summary (printSummary). */
class RunSession
{
public:
  RunSession (const RunSettings& s, const po::variables_map& vm);

  /** Grabs every frame (a recorded sequence) or until Ctrl-C / the grabber stops (a live
    * camera); with --view the window runs on this thread and the frames on a worker. */
  void run ();

  /** Writes the staged outputs and replaces the folder's previous set with them. */
  void writeOutputs ();

  void printSummary () const;

private:
  /** A live camera's frame (the grabber's callback). */
  void onFrame (const RGBDFrame::ConstPtr& frame);
  /** One frame through the pipeline; \a read_ms: the time reading it took (a recorded
    * sequence); \a masks_ahead: its masks, computed ahead (null: the mask source runs here). */
  void processFrame (const RGBDFrame::ConstPtr& frame, std::optional<double> read_ms, recognition::PreparedFrame* masks_ahead);
  /** A recorded sequence: frames read (and masked) ahead on another thread, or one after
    * the other with --sequential. */
  void processRecording ();
  /** Whether frames get masks: a mask source, and a mode that uses them. */
  bool usesMasks () const { return mask_source_ && pipeline_config_.mode != pipeline::SegmentationMode::Geometry; }
  /** The frame's masks from the mask source (or \a masks_ahead's); false when it has none. */
  bool masksFor (const RGBDFrame& frame, std::vector<Instance>& instances, recognition::PreparedFrame* masks_ahead,
                 std::optional<std::size_t>& masks_frame);
  /** labels/INDEX.png, --render's PNG and --video's frame of a segmented frame. */
  void writeFrameViews (const RGBDFrame& frame);
  void postToViewer (const RGBDFrame& frame, const reconstruction::FrameReport& report);
  void grabFrames ();
  void runWithViewer ();
  nlohmann::json trackingJson ();
  /** The staging path of \a name; throws when a second signal came while writing. */
  std::string staged (const std::string& name) const;
  /** outputs.json's record of the run: what ran, on what, the files, the model's sha256. */
  pipeline::RunManifest manifest () const;

  /// First: a signal while the session sets up (after the output set's staging folder
  /// exists) stops it before its first frame with its outputs written, instead of ending
  /// the process with a staging folder left behind. A second keeps the old set.
  InterruptHandlers interrupts_;
  const RunSettings& s_;
  const pipeline::FusionPipelineConfig pipeline_config_;
  std::shared_ptr<recognition::InstanceSegmenter> mask_source_;  ///< released when the frames are done
  std::string mask_source_name_;                                  ///< its name, for tracking.json
  io::RGBDGrabber::Ptr grabber_;
  io::DatasetGrabber::Ptr dataset_;  ///< the grabber when it reads a recorded sequence
  bool asynchronous_masks_ = false;
  io::OutputSet outputs_;
  pipeline::FusionPipeline fusion_;
  std::unique_ptr<VideoSink> video_;
  std::unique_ptr<ViewerWindow> viewer_;
  std::chrono::steady_clock::time_point last_view_post_ = std::chrono::steady_clock::now () - std::chrono::seconds (10);
  pipeline::RunRecord result_;
  std::mutex mutex_;
  std::string callback_error_;
  bool callback_error_named_ = false;  ///< callback_error_ names its file (else: the sequence's)
  ProgressReporter progress_;
  std::chrono::steady_clock::time_point t0_;
  std::chrono::steady_clock::time_point last_frame_end_;
  // What writeOutputs found, for printSummary.
  double seconds_ = 0.0;
  std::size_t map_points_ = 0, triangles_ = 0, lost_ = 0, relocalised_ = 0;
  std::vector<segmentation::SegmentRecord> segments_;
  std::string ate_line_;
};

std::shared_ptr<recognition::InstanceSegmenter>
makeMaskSource (const RunSettings& s)
{
  recognition::InstanceSegmenter::Ptr source;
  if (!s.masks.empty ())
    source = std::make_shared<recognition::MaskFolderSegmenter> (s.masks);
  else if (!s.onnx.model_path.empty ())
    source = std::make_shared<recognition::OnnxInstanceSegmenter> (s.onnx);
  if (source && s.masks_every > 1)
    source = std::make_shared<recognition::PeriodicSegmenter> (source, static_cast<std::size_t> (s.masks_every));
  return source;
}

/** --out, once the settings are known to suit the sequence (\a dataset: null for a camera). */
const std::string&
checkedOutputFolder (const RunSettings& s, const io::DatasetGrabber* dataset)
{
  if (s.pipeline.reconstruction.use_reference_poses && (!dataset || !dataset->hasPoses ()))
    throw ParameterError ("--use-gt-poses", s.source + " has no reference poses");
  return s.out;
}

io::RGBDGrabber::Ptr
openRunSequence (const RunSettings& s)
{
  io::SequenceOptions opts;
  opts.format = io::parseSequenceFormat (s.format);
  opts.intrinsics_path = s.intrinsics;
  return io::openSequence (s.source, opts);
}

RunSession::RunSession (const RunSettings& s, const po::variables_map& vm)
  : interrupts_ ()
  , s_ (s)
  , pipeline_config_ (runPipelineConfig (s))
  , mask_source_ (makeMaskSource (s))
  , grabber_ (openRunSequence (s))
  , dataset_ (std::dynamic_pointer_cast<io::DatasetGrabber> (grabber_))
  // Everything goes to a staging folder first and replaces the previous run's set as a
  // whole at the end (io::OutputSet): an error or a second signal leaves it untouched.
  , outputs_ (checkedOutputFolder (s, dataset_.get ()), kRunOutputs, "outputs.json")
  , fusion_ (pipeline_config_)
  , progress_ ("run", dataset_ ? dataset_->size () : 0)
{
  const std::size_t max_frames = static_cast<std::size_t> (s.frames);
  if (dataset_)
    dataset_->setFrameLimit (max_frames);
  // A live camera does not wait for the network (thesis §6.1).
  asynchronous_masks_ = mask_source_ && (s.async_masks || !dataset_);
  if (asynchronous_masks_)  // the first frames go without masks until the first finish
    mask_source_ = std::make_shared<recognition::AsynchronousSegmenter> (mask_source_);
  if (!s.load_volume.empty ())
    continueSavedVolume (s.load_volume, vm, pipeline_config_.reconstruction.keyframes, fusion_);
  boost::system::error_code ec;
  if (!s.render_dir.empty ())
  {
    fs::create_directories (s.render_dir, ec);
    if (ec || !fs::is_directory (s.render_dir))
      throw Error (s.render_dir, "cannot create folder" + (ec ? ": " + ec.message () : std::string ()));
  }
  if (!s.video_path.empty ())
  {
    const std::string ext = fs::path (s.video_path).extension ().string ();
    if (ext != ".avi" && ext != ".mp4")
      throw ParameterError ("--video", "the file must end in .avi or .mp4, not '" + ext + "'");
    video_ = loadRunDisplay ().openVideo (s.video_path, dataset_ && dataset_->getFramesPerSecond () > 0.f
                                                          ? dataset_->getFramesPerSecond ()
                                                          : 30.0);
  }
  // The window belongs to this (the main) thread; processing moves to a worker in run().
  if (s.view)
    viewer_ = loadRunDisplay ().openViewer ("cuefusion run: " + s.source);
}

bool
RunSession::masksFor (const RGBDFrame& frame, std::vector<Instance>& instances, recognition::PreparedFrame* masks_ahead,
                      std::optional<std::size_t>& masks_frame)
{
  if (!usesMasks ())
    return false;
  bool have_masks = false;
  if (masks_ahead)
  {
    result_.masks_ms.push_back (masks_ahead->masks_ms);
    result_.masks_stages.push_back (masks_ahead->masks_stages);
    if (masks_ahead->mask_error)
      std::rethrow_exception (masks_ahead->mask_error);
    have_masks = masks_ahead->have_masks;
    instances = std::move (masks_ahead->instances);
    masks_frame = masks_ahead->masks_frame;
  }
  else
  {
    const auto t0 = std::chrono::steady_clock::now ();
    have_masks = mask_source_->segment (frame, instances);
    result_.masks_ms.push_back (std::chrono::duration<double, std::milli> (std::chrono::steady_clock::now () - t0).count ());
    result_.masks_stages.push_back (mask_source_->lastTimings ());
    masks_frame = mask_source_->lastResultFrame ();
  }
  if (!have_masks && result_.frames_without_masks++ == 0 && !asynchronous_masks_)
    std::cerr << "cuefusion run: no masks for frame " << frame.index << " (nor, maybe, for later frames): "
              << "geometry only there\n";
  return have_masks;
}

void
RunSession::writeFrameViews (const RGBDFrame& frame)
{
  std::ostringstream name;
  name << std::setw (6) << std::setfill ('0') << frame.index << ".png";
  const std::size_t save_every = static_cast<std::size_t> (s_.save_every);
  const bool save_labels = save_every > 0 && frame.index % save_every == 0;
  if (!save_labels && s_.render_dir.empty () && !video_)
    return;
  const cv::Mat labels = fusion_.modelLabels ();
  if (save_labels)
  {
    const std::string path = outputs_.stagingPath ("labels/" + name.str ());
    io::writeImageAtomic (path, labelsAs16Bit (labels, outputs_.finalPath ("labels/" + name.str ())));
  }
  if (!s_.render_dir.empty () || video_)
  {
    const cv::Mat panel = visualization::composeFrameView (frame, labels);
    if (!s_.render_dir.empty ())
      io::writeImageAtomic ((fs::path (s_.render_dir) / name.str ()).string (), panel);
    if (video_)
      video_->write (panel);
  }
}

void
RunSession::postToViewer (const RGBDFrame& frame, const reconstruction::FrameReport& report)
{
  if (!viewer_ || !report.tracked)
    return;
  // The map is re-extracted at most twice a second: it grows with the scene.
  const auto now = std::chrono::steady_clock::now ();
  viewer_->postFrame (frame.camera, report.pose, toPointCloud (frame));
  if (now - last_view_post_ > std::chrono::milliseconds (500))
  {
    viewer_->postMap (fusion_.labelledCloud ());
    last_view_post_ = now;
  }
}

void
RunSession::onFrame (const RGBDFrame::ConstPtr& frame)
{
  processFrame (frame, std::nullopt, nullptr);
}

void
RunSession::processFrame (const RGBDFrame::ConstPtr& frame, std::optional<double> read_ms, recognition::PreparedFrame* masks_ahead)
{
  const std::lock_guard<std::mutex> lock (mutex_);
  const std::size_t max_frames = static_cast<std::size_t> (s_.frames);
  if (!callback_error_.empty () || (max_frames && result_.reports.size () >= max_frames))
    return;
  try
  {
    // The sequence's own pose, integrated as it is: beyond the volume's reach it is the
    // pose file's fault, and the error names that file and the frame.
    if (s_.pipeline.reconstruction.use_reference_poses && frame->pose && !fusion_.reconstruction ().volume ().reaches (*frame->pose))
    {
      const Eigen::Vector3d t = frame->pose->translation ();
      std::ostringstream why;
      why << "frame " << frame->name << " puts the camera at (" << t.x () << ", " << t.y () << ", " << t.z ()
          << ") m, outside the volume's addressable range (±" << fusion_.reconstruction ().volume ().addressableReach ()
          << " m from the origin at --voxel " << fusion_.reconstruction ().volume ().getConfig ().voxel_size << " m)";
      const std::string pose_file = dataset_ && frame->index < dataset_->size () ? dataset_->records ()[frame->index].pose_source : "";
      callback_error_ = Error (pose_file.empty () ? s_.source : pose_file, why.str ()).what ();
      callback_error_named_ = true;
      return;
    }
    std::vector<Instance> instances;
    std::optional<std::size_t> masks_frame;  // when the masks are an earlier frame's (async, --masks-every)
    const bool have_masks = masksFor (*frame, instances, masks_ahead, masks_frame);
    const pipeline::PipelineFrameReport full = fusion_.process (*frame, have_masks ? &instances : nullptr, masks_frame);
    reconstruction::FrameReport report = full.reconstruction;
    if (full.segmented)
    {
      result_.segmentation.push_back (full.segmentation);
      result_.loop_ms.push_back (full.loop_ms);
      result_.merges += full.merges;
      writeFrameViews (*frame);
    }
    postToViewer (*frame, report);
    if (report.tracked)
      result_.trajectory.push_back ({frame->timestamp, report.pose});
    if (frame->pose)
      result_.reference.push_back ({frame->timestamp, *frame->pose});
    result_.reports.push_back (std::move (report));
    result_.volume_bytes.push_back (fusion_.reconstruction ().volume ().memoryUsage ());
    if (read_ms)
      result_.read_ms.push_back (*read_ms);
    const auto now = std::chrono::steady_clock::now ();
    result_.wall_ms.push_back (std::chrono::duration<double, std::milli> (now - last_frame_end_).count ());
    last_frame_end_ = now;
    progress_.update (result_.reports.size ());
  }
  catch (const std::exception& e)  // a live camera's thread must not die with an exception
  {
    callback_error_ = describeException (e);
  }
}

void
RunSession::grabFrames ()
{
  grabber_->start ();
  if (dataset_)
    processRecording ();
  else
  {
    std::cerr << "cuefusion run: reconstructing from " << s_.source << "; Ctrl-C stops and writes the map\n";
    const std::size_t max_frames = static_cast<std::size_t> (s_.frames);
    for (;;)
    {
      std::this_thread::sleep_for (std::chrono::milliseconds (20));
      const std::lock_guard<std::mutex> lock (mutex_);
      if (InterruptHandlers::interrupted () || !grabber_->isRunning () || !callback_error_.empty () ||
          (max_frames && result_.reports.size () >= max_frames))
        break;
    }
  }
  grabber_->stop ();
}

void
RunSession::processRecording ()
{
  const auto failed = [this] {
    const std::lock_guard<std::mutex> lock (mutex_);
    return !callback_error_.empty ();
  };
  if (s_.sequential)
  {
    for (std::size_t i = 0; i < dataset_->size () && !InterruptHandlers::interrupted () && !failed (); ++i)
    {
      const auto t0 = std::chrono::steady_clock::now ();
      const RGBDFrame::ConstPtr frame = dataset_->readFrame (i);
      processFrame (frame, std::chrono::duration<double, std::milli> (std::chrono::steady_clock::now () - t0).count (), nullptr);
    }
    return;
  }
  // The masks of a frame do not depend on the map: reading, decoding and the network run
  // one or two frames ahead of the loop, and every frame still gets its own masks. With
  // --async-masks the mask source stays in the loop (it hands out its newest masks).
  const bool masks_ahead = usesMasks () && !asynchronous_masks_;
  const io::DatasetGrabber::Ptr dataset = dataset_;
  recognition::FramePrefetcher ahead ([dataset] (std::size_t i) { return dataset->readFrame (i); }, dataset_->size (),
                                      masks_ahead ? mask_source_ : nullptr);
  while (!InterruptHandlers::interrupted () && !failed ())
  {
    std::optional<recognition::PreparedFrame> prepared = ahead.next ();
    if (!prepared)
      break;
    processFrame (prepared->frame, prepared->read_ms, masks_ahead ? &*prepared : nullptr);
  }
}

void
RunSession::runWithViewer ()
{
  std::atomic<bool> done{false};
  std::thread worker ([&] {
    try
    {
      grabFrames ();
    }
    catch (const std::exception& e)
    {
      const std::lock_guard<std::mutex> lock (mutex_);
      callback_error_ = describeException (e);
    }
    done = true;
  });
  bool window_open = true;
  while (!done)
    if (window_open && !viewer_->spinOnce (30))
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
    viewer_->postMap (fusion_.labelledCloud ());
    viewer_->spinOnce (30);
    if (!s_.screenshot.empty ())
      viewer_->saveScreenshot (s_.screenshot);
    else
    {
      std::cerr << "cuefusion run: done; close the window to write the outputs\n";
      viewer_->setFollowCamera (false);  // the mouse has the view now
      while (viewer_->spinOnce (30))
      {
      }
    }
  }
  viewer_.reset ();
}

void
RunSession::run ()
{
  t0_ = std::chrono::steady_clock::now ();
  last_frame_end_ = t0_;
  const boost::signals2::connection connection =
    grabber_->registerCallback (std::function<io::RGBDGrabber::sig_cb_rgbd_frame> ([this] (const RGBDFrame::ConstPtr& frame) { onFrame (frame); }));
  if (viewer_)
    runWithViewer ();
  else
    grabFrames ();
  connection.disconnect ();
  progress_.finish ();
  // The network's buffers are not needed for the outputs: freed before the mesh, which is
  // what the run peaks at.
  mask_source_name_ = mask_source_ ? mask_source_->name () : std::string ();
  mask_source_.reset ();
  if (!callback_error_.empty ())
    throw callback_error_named_ ? Error (callback_error_) : Error (s_.source, callback_error_);
  if (!grabber_->lastError ().empty ())
    throw Error (s_.source, grabber_->lastError ());
  if (result_.reports.empty ())
    throw Error (s_.source, InterruptHandlers::interrupted ()
                              ? "stopped by a signal before the first frame: nothing written, the folder's previous outputs are unchanged"
                              : "no frame was processed");
  seconds_ = std::chrono::duration<double> (std::chrono::steady_clock::now () - t0_).count ();
}

std::string
RunSession::staged (const std::string& name) const
{
  // A second signal while writing abandons the set; checked between the files.
  if (InterruptHandlers::interruptedTwice ())
    throw Error (s_.out, "interrupted again while writing the outputs: nothing written, the folder's previous outputs are unchanged");
  return outputs_.stagingPath (name);
}

nlohmann::json
RunSession::trackingJson ()
{
  pipeline::TrackingFileContext context;
  context.mask_source = mask_source_name_;
  context.continued_from = s_.load_volume;
  if (!s_.pipeline.reconstruction.use_reference_poses && result_.reference.size () >= 3 && result_.trajectory.size () >= 3)
  {
    const evaluation::TrajectoryError ate = evaluation::absoluteTrajectoryError (result_.trajectory, result_.reference, 1e-4);
    context.ate = pipeline::TrackingAccuracy{ate.rmse, ate.mean, ate.median, ate.max, ate.pairs};
    std::ostringstream line;
    line << std::fixed << std::setprecision (4) << "  ATE RMSE:   " << ate.rmse << " m against the sequence's poses ("
         << ate.pairs << " frames)\n";
    ate_line_ = line.str ();
  }
  const nlohmann::json tracking = pipeline::trackingJson (result_, fusion_, context);
  lost_ = tracking["lost"].size ();
  relocalised_ = tracking["relocalised"].size ();
  return tracking;
}

pipeline::RunManifest
RunSession::manifest () const
{
  pipeline::RunManifest m;
  m.sequence = s_.source;
  m.frames = result_.reports.size ();
  m.seconds = seconds_;
  m.stopped_early = dataset_ != nullptr && InterruptHandlers::interrupted ();
  for (const std::string& name : kRunOutputs)
    if (fs::exists (fs::path (outputs_.stagingPath (name))))
      m.files.push_back (name);
  // What ran, to repeat it: the arguments as given (`cuefusion run` then these repeats the
  // run exactly: offline runs are frame-exact), the working folder they are relative to,
  // the settings as one settings file, and the network by its bytes.
  m.command_line = {"run"};
  m.command_line.insert (m.command_line.end (), s_.command_line.begin (), s_.command_line.end ());
  m.working_directory = fs::current_path ().string ();
  m.config = runConfigJson (s_);
  if (!s_.onnx.model_path.empty ())
  {
    const std::string model = findDataFile (s_.onnx.model_path, "models", ".onnx");
    m.model_path = fs::absolute (model).string ();
    m.model_sha256 = io::sha256OfFile (model);
  }
  return m;
}

void
RunSession::writeOutputs ()
{
  // One product in memory at a time: on a large map the mesh is what the run peaks at.
  std::map<std::uint32_t, segmentation::ObjectGeometry> geometry;
  {
    const pcl::PointCloud<pcl::PointXYZRGBL>::Ptr map = fusion_.labelledCloud (s_.colors == "segments");
    io::saveMapPCD (staged ("map.pcd"), *map);
    map_points_ = map->size ();
    geometry = segmentation::objectGeometry (*map);
  }
  {
    const io::TriangleMesh mesh = fusion_.labelledTriangleMesh (s_.colors != "surface");
    io::writeMeshPLY (staged ("mesh.ply"), mesh);
    triangles_ = mesh.triangles.size ();
    if (s_.export_objects)
      for (const auto& [label, part] : io::splitByLabel (mesh))
        io::writeMeshPLY (staged ("objects/" + std::to_string (label) + ".ply"), part);
  }
  segments_ = fusion_.segments ();
  segmentation::writeSegmentsJson (staged ("segments.json"), segments_, geometry);
  io::writeTumTrajectory (staged ("trajectory.txt"), result_.trajectory);
  if (!result_.reference.empty ())  // for evaluating the estimate with any TUM tool
    io::writeTumTrajectory (staged ("reference_trajectory.txt"), result_.reference);
  if (s_.save_volume)
    fusion_.saveVolume (staged ("volume.tsdf"), staged ("volume.labels"), staged ("volume.keyframes"));
  io::writeTextAtomic (staged ("tracking.json"), io::jsonText (trackingJson (), 2) + "\n");
  io::writeTextAtomic (staged ("timings.json"),
                       io::jsonText (pipeline::timingsJson (result_, seconds_), 2) + "\n");
  io::writeTextAtomic (staged ("outputs.json"), io::jsonText (pipeline::outputsJson (manifest ()), 2) + "\n");
  if (video_)
    video_->finish ();
  outputs_.commit ();
}

void
RunSession::printSummary () const
{
  const fs::path dir (s_.out);
  const reconstruction::TSDFVolume& volume = fusion_.reconstruction ().volume ();
  const segmentation::FragmentationReport fragmentation = segmentation::fragmentationReport (segments_);
  std::cout << "processed " << result_.reports.size () << " frames of " << s_.source << " (" << grabber_->formatName ()
            << ") in " << std::fixed << std::setprecision (2) << seconds_ << " s; " << result_.trajectory.size ()
            << " fused" << std::defaultfloat;
  if (lost_ > 0)
    std::cout << ", " << lost_ << " lost (tracking.json lists them)";
  if (relocalised_ > 0)
    std::cout << ", " << relocalised_ << " relocalised";
  std::cout << "\n"
            << ate_line_ << "  map:        " << (dir / "map.pcd").string () << " (" << map_points_ << " points)\n"
            << "  mesh:       " << (dir / "mesh.ply").string () << " (" << triangles_ << " triangles)\n"
            << "  trajectory: " << (dir / "trajectory.txt").string () << " (" << result_.trajectory.size ()
            << " poses, TUM format)\n"
            << "  segments:   " << (dir / "segments.json").string () << " (" << segments_.size () << " segments, "
            << std::count_if (segments_.begin (), segments_.end (), [] (const segmentation::SegmentRecord& r) {
                 return !r.bestClass ().empty ();
               })
            << " with a class; mode " << pipeline::segmentationModeName (pipeline_config_.mode) << ", " << result_.merges
            << " merges)\n"
            << "  fragments:  " << fragmentation.segments_at_least_100 () << " segments of >= 100 voxels; "
            << std::fixed << std::setprecision (1) << 100.0 * fragmentation.shareBelow (1000)
            << " % of the surface in segments below 1000 voxels\n"
            << "  noise:      depth noise " << std::setprecision (2) << fusion_.noiseScale () << " x the Kinect model's"
            << (s_.pipeline.geometry.noise_scale > 0.f ? " (--noise-scale)" : " (measured; --noise-scale sets it)") << "\n"
            << std::defaultfloat
            << "  volume:     " << volume.blockCount () << " blocks, "
            << volume.memoryUsage () / (1024 * 1024) << " MiB\n";
}
}  // namespace

int
runRun (const std::vector<std::string>& args)
{
  // Parse → set up → process the frames → write → report.
  RunSettings settings;
  loadRunConfig (args, settings);
  po::options_description options ("options");
  options.add_options ()
    ("sequence", po::value (&settings.source), "dataset folder, openni2[:DEVICE] or .oni file")
    ("out", po::value (&settings.out), "output folder");
  addRunOptions (options, settings);
  po::positional_options_description positional;
  positional.add ("sequence", 1);
  po::variables_map vm;
  if (!parseCommandLine ("run", "SEQUENCE --out DIR [options]", args, options, positional, vm))
    return 0;
  checkRunSettings (settings);
  if (settings.print_config)
  {
    std::cout << io::jsonText (runConfigJson (settings), 2) << "\n";
    return 0;
  }
  for (const char* required : {"sequence", "out"})  // not needed to print the settings
    if (!vm.count (required))
      throw UsageError (std::string ("the option '--") + required + "' is required but missing");
  settings.command_line = args;
#if defined(__GLIBC__)
  // One malloc arena for every thread: glibc gives each thread that allocates (the thread
  // reading and masking frames ahead, OpenCV's pool) an arena of its own, whose freed
  // memory the others cannot reuse. Measured on 7-Scenes kitchen fused with the network,
  // read ahead: peak resident 339 -> 296 MiB (the sequential run's 298), time unchanged.
  mallopt (M_ARENA_MAX, 1);
#endif
  RunSession session (settings, vm);
  session.run ();
  session.writeOutputs ();
  session.printSummary ();
  return 0;
}
}  // namespace cli
}  // namespace cuefusion
