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
#include <cuefusion/pipeline/settings.h>
#include <cuefusion/recognition/settings.h>
#include <cuefusion/segmentation/fragmentation.h>
#include <cuefusion/segmentation/object_geometry.h>
#include <cuefusion/segmentation/segments_file.h>
#include <cuefusion/recognition/asynchronous_segmenter.h>
#include <cuefusion/recognition/frame_prefetcher.h>
#include <cuefusion/recognition/mask_folder_segmenter.h>
#include <cuefusion/recognition/onnx_instance_segmenter.h>
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

struct RunOutputs
{
  io::Trajectory trajectory;            ///< accepted poses
  io::Trajectory reference;             ///< the sequence's own poses, where it has them
  std::vector<reconstruction::FrameReport> reports;
  std::vector<pipeline::SegmentationTimings> segmentation;  ///< per segmented frame
  std::vector<std::size_t> volume_bytes;  ///< after each frame: memory growth over the run
  std::vector<double> loop_ms;            ///< per segmented frame: every stage, the mask source excluded
  std::vector<double> read_ms;            ///< per frame: reading and decoding its files (recorded sequences)
  std::vector<double> masks_ms;           ///< per frame: the mask source (the network) on it; 0 without one
  std::vector<recognition::SegmenterTimings> masks_stages;  ///< per frame: the network's input, forward pass, decoding
  std::vector<double> wall_ms;            ///< per frame: from the previous frame's end to this one's
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

/** One stage of the network over the frames that ran it (a source that does not time its
  * stages gives none). */
std::vector<double>
maskStage (const RunOutputs& run, double recognition::SegmenterTimings::*stage)
{
  std::vector<double> out;
  for (const recognition::SegmenterTimings& t : run.masks_stages)
    if (t.input_ms + t.forward_ms + t.decode_ms > 0.0)
      out.push_back (t.*stage);
  return out;
}

/** timings.json: per frame every stage (reading, the mask source, the loop's stages, the
  * wall time), their medians and 90th percentiles, the run's frames per second. */
nlohmann::json
timingsJson (const RunOutputs& run, double seconds)
{
  const std::vector<reconstruction::FrameReport>& reports = run.reports;
  const auto at = [] (const std::vector<double>& v, std::size_t k) { return k < v.size () ? v[k] : 0.0; };
  std::vector<double> pre, track, integrate, raycast, core, relocalise, lost;
  nlohmann::json frames = nlohmann::json::array ();
  for (std::size_t k = 0; k < reports.size (); ++k)
  {
    const auto& r = reports[k];
    const auto& t = r.timings;
    const recognition::SegmenterTimings stages = k < run.masks_stages.size () ? run.masks_stages[k] : recognition::SegmenterTimings ();
    frames.push_back ({{"index", r.index}, {"read_ms", at (run.read_ms, k)}, {"masks_ms", at (run.masks_ms, k)},
                       {"masks_input_ms", stages.input_ms}, {"masks_forward_ms", stages.forward_ms}, {"masks_decode_ms", stages.decode_ms},
                       {"preprocess_ms", t.preprocess_ms}, {"track_ms", t.track_ms},
                       {"integrate_ms", t.integrate_ms}, {"raycast_ms", t.raycast_ms}, {"relocalise_ms", t.relocalise_ms},
                       {"wall_ms", at (run.wall_ms, k)},
                       {"volume_mib", k < run.volume_bytes.size () ? static_cast<double> (run.volume_bytes[k]) / (1024.0 * 1024.0) : 0.0}});
    if (t.relocalise_ms > 0.0)  // frames whose tracking failed, relocalised or not
      relocalise.push_back (t.relocalise_ms);
    if (!r.tracked)
    {
      lost.push_back (t.preprocess_ms + t.track_ms + t.relocalise_ms);  // all a lost frame costs
      continue;
    }
    pre.push_back (t.preprocess_ms);
    track.push_back (t.track_ms);
    integrate.push_back (t.integrate_ms);
    raycast.push_back (t.raycast_ms);
    core.push_back (t.track_ms + t.integrate_ms + t.raycast_ms);
  }
  std::vector<double> geometry, instances, propagation, merging, update, segmentation_total;
  for (const auto& t : run.segmentation)
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
                      {"lost frame (preprocess+track+relocalise)", timingSummary (lost)},
                      {"geometric segmentation", timingSummary (geometry)}, {"instance merge", timingSummary (instances)},
                      {"propagation", timingSummary (propagation)}, {"segment merging", timingSummary (merging)},
                      {"label update", timingSummary (update)}, {"segmentation", timingSummary (segmentation_total)},
                      {"whole loop", timingSummary (run.loop_ms)}, {"read", timingSummary (run.read_ms)},
                      {"masks", timingSummary (run.masks_ms)}, {"masks: input", timingSummary (maskStage (run, &recognition::SegmenterTimings::input_ms))},
                      {"masks: forward", timingSummary (maskStage (run, &recognition::SegmenterTimings::forward_ms))},
                      {"masks: decode", timingSummary (maskStage (run, &recognition::SegmenterTimings::decode_ms))},
                      {"wall per frame", timingSummary (run.wall_ms)}}},
          {"frames_per_second", seconds > 0.0 ? static_cast<double> (reports.size ()) / seconds : 0.0},
          {"peak_memory_mib", peakMemoryMiB ()},
          {"frames", frames}};
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

void
loadRunConfig (const std::vector<std::string>& args, RunSettings& s)
{
  readConfigParts ("run", args,
                   {{"pipeline",
                     [&s] (const nlohmann::json& part) {
                       pipeline::readConfig (part, s.pipeline);
                       if (part.contains ("mode"))
                         s.mode = pipeline::segmentationModeName (s.pipeline.mode);
                     }},
                    {"network", [&s] (const nlohmann::json& part) { recognition::readConfig (part, s.onnx); }}});
}

namespace
{
/** \a text with the default \a value, for options that set a field only when given. */
std::string
withDefault (const std::string& text, double value)
{
  std::ostringstream out;
  out << text << " (default " << value << ")";
  return out.str ();
}
}  // namespace

void
addRunOptions (po::options_description& options, RunSettings& s)
{
  reconstruction::DenseReconstructionConfig& r = s.pipeline.reconstruction;
  options.add_options ()
    ("config", po::value<std::string> (), "settings file (JSON; the library's Config fields by name, see --print-config) or a "
     "run's outputs.json to repeat its settings; options given on the command line override it")
    ("print-config", po::bool_switch (&s.print_config), "print the settings this run would use (defaults, --config, options) as a settings file, and stop")
    ("frames", po::value (&s.frames)->default_value (s.frames), "process at most N frames (0 = all)")
    ("format", po::value (&s.format)->default_value (s.format), "auto, tum, redwood, 7scenes, scannet, openni2")
    ("intrinsics", po::value (&s.intrinsics), "intrinsics file overriding the sequence's own")
    ("voxel", po::value (&r.volume.voxel_size)->default_value (r.volume.voxel_size), "TSDF voxel size in metres")
    ("truncation", po::value (&r.volume.truncation_voxels)->default_value (r.volume.truncation_voxels), "TSDF truncation distance in voxels")
    ("max-depth", po::value<double> ()->notifier ([&r] (double d) { r.volume.max_depth = r.preprocessing.max_depth = d; }),
     withDefault ("ignore depth beyond this (metres)", r.volume.max_depth).c_str ())
    ("use-gt-poses", setsWhenGiven (r.use_reference_poses, true), "integrate with the sequence's own poses instead of tracking")
    ("no-motion-model", setsWhenGiven (r.motion_model, false), "tracking: start ICP at the last pose instead of the constant-velocity prediction")
    ("no-features", setsWhenGiven (r.feature_relocalisation, false), "relocalisation: no colour features (keyframes and the motion model only)")
    ("no-noise-weighting", setsWhenGiven (r.tracking.icp.noise_weighting, false), "tracking: every ICP term counts the same, instead of by the inverse depth-noise variance")
    ("hole-refresh", po::value (&r.hole_refresh_period)->default_value (r.hole_refresh_period), "raycast: rays behind depth holes that found no surface are searched again every N frames (1 = every frame)")
    ("colors", po::value (&s.colors), "colour map.pcd and mesh.ply alike: segments (each segment its label's colour, none grey) or "
     "surface (the fused colour); without it map.pcd has the surface colour and mesh.ply the segments'")
    ("export-objects", po::bool_switch (&s.export_objects), "also write each object's part of the mesh as objects/ID.ply (ID as in segments.json, which gives every segment's centroid and oriented box)")
    ("save-volume", po::bool_switch (&s.save_volume), "also write the TSDF volume (volume.tsdf), its voxels' labels as map.pcd's (volume.labels) and the relocalisation keyframes (volume.keyframes)")
    ("load-volume", po::value (&s.load_volume), "continue a saved volume.tsdf (with the volume.labels and volume.keyframes beside it): the first frame is relocalised in it, its objects are kept")
    ("mode", po::value (&s.mode), "fused (geometry grouped by instance masks; the default with --masks/--model), geometry, or masks")
    ("noise-scale", po::value (&s.pipeline.geometry.noise_scale)->default_value (s.pipeline.geometry.noise_scale),
     "the depth's noise as a multiple of the Kinect model's, which scales every noise threshold (0 = measured on the first frames)")
    ("color-split", po::value (&s.pipeline.instance_merge.color_split_distance)->default_value (s.pipeline.instance_merge.color_split_distance),
     "fused: a mask is cut between the segments it claims whose colours lie this far apart (rg chromaticity; 0 = never)")
    ("masks", po::value (&s.masks), "folder of per-frame 16-bit instance-id PNGs (+ JSON), matched by frame name or index")
    ("model", po::value (&s.onnx.model_path), "instance masks from an ONNX model (OpenCV DNN, CPU): cuefusion's depth network by name, "
     "xyz_instances (found in the data directory from any folder), or the path of an .onnx file such as a YOLO-seg export run on the colour image")
    ("classes", po::value (&s.onnx.classes_path), "class names of --model (default data/classes/coco.names)")
    ("input-size", po::value (&s.onnx.input_size)->default_value (s.onnx.input_size), "network input size of --model (px)")
    ("score-threshold", po::value (&s.onnx.score_threshold)->default_value (s.onnx.score_threshold), "--model detections below are dropped")
    ("boundary-threshold", po::value (&s.onnx.boundary_threshold)->default_value (s.onnx.boundary_threshold),
     "--model of the xyz layout: instances are cut where the boundary probability reaches this")
    ("async-masks", po::bool_switch (&s.async_masks), "run the mask source on its own thread and use its newest finished masks (always on for live cameras; offline runs are otherwise frame-exact)")
    ("sequential", po::bool_switch (&s.sequential), "a recorded sequence: read, mask and process each frame in turn instead of reading and masking the next frames while the loop runs (the same outputs; slower, for profiling)")
    ("save-every", po::value (&s.save_every)->default_value (s.save_every), "every K-th frame, write the map's segment ids seen from the camera to labels/INDEX.png (16-bit; 0 = never)")
    ("render", po::value (&s.render_dir), "write per-frame PNGs to DIR: input colour, depth and the map's segments seen from the camera")
    ("video", po::value (&s.video_path), "the same panels as a video (.avi Motion-JPEG or .mp4)")
    ("view", po::bool_switch (&s.view), "show the map growing in a PCLVisualizer window (needs a display)")
    ("view-screenshot", po::value (&s.screenshot), "with --view: save the window as PNG when the run ends and close it");
}

nlohmann::json
runConfigJson (const RunSettings& s)
{
  return {{"pipeline", pipeline::configJson (runPipelineConfig (s))}, {"network", recognition::configJson (s.onnx)}};
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
  if (!s.load_volume.empty () && !s.save_volume)  // the new set, without a volume, would remove the loaded one
    refuseOutputsOverInputs ({{"--out", s.out}}, {{"--load-volume (add --save-volume to replace it)", boost::filesystem::absolute (s.load_volume).parent_path ().string ()}});
  io::parseSequenceFormat (s.format);
  if (!s.colors.empty () && s.colors != "segments" && s.colors != "surface")
    throw ParameterError ("--colors", "must be segments or surface, not '" + s.colors + "'");
  // The library's own checks, named by field (main() translates them into the options).
  runPipelineConfig (s).validate ();
  if (!s.onnx.model_path.empty ())
    s.onnx.validate ();  // the segmenter checks it again when it is built
}

pipeline::SegmentationMode
chooseSegmentationMode (const std::string& mode, const std::string& masks, const std::string& model)
{
  if (!masks.empty () && !model.empty ())
    throw UsageError ("--masks and --model exclude each other");
  const bool have_source = !masks.empty () || !model.empty ();
  const pipeline::SegmentationMode chosen = pipeline::parseSegmentationMode (mode.empty () ? (have_source ? "fused" : "geometry") : mode);
  if (chosen != pipeline::SegmentationMode::Geometry && !have_source)
    throw UsageError ("--mode " + mode + " needs --masks or --model");
  return chosen;
}

pipeline::FusionPipelineConfig
runPipelineConfig (const RunSettings& s)
{
  pipeline::FusionPipelineConfig pipeline_config = s.pipeline;
  pipeline_config.mode = chooseSegmentationMode (s.mode, s.masks, s.onnx.model_path);
  return pipeline_config;
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
  /** The frame's masks from the mask source (or \a masks_ahead's); false when it has none. */
  bool masksFor (const RGBDFrame& frame, std::vector<Instance>& instances, recognition::PreparedFrame* masks_ahead);
  /** labels/INDEX.png, --render's PNG and --video's frame of a segmented frame. */
  void writeFrameViews (const RGBDFrame& frame);
  void postToViewer (const RGBDFrame& frame, const reconstruction::FrameReport& report);
  void grabFrames ();
  void runWithViewer ();
  nlohmann::json trackingJson ();
  /** The staging path of \a name; throws when a second signal came while writing. */
  std::string staged (const std::string& name) const;
  /** outputs.json's record of what ran: command line, working folder, the model's sha256. */
  nlohmann::json withProvenance (nlohmann::json manifest) const;

  /// First: a signal while the session sets up (after the output set's staging folder
  /// exists) stops it before its first frame with its outputs written, instead of ending
  /// the process with a staging folder left behind. A second keeps the old set.
  InterruptHandlers interrupts_;
  const RunSettings& s_;
  const pipeline::FusionPipelineConfig pipeline_config_;
  std::shared_ptr<recognition::InstanceSegmenter> mask_source_;
  io::RGBDGrabber::Ptr grabber_;
  io::DatasetGrabber::Ptr dataset_;  ///< the grabber when it reads a recorded sequence
  bool asynchronous_masks_ = false;
  io::OutputSet outputs_;
  pipeline::FusionPipeline fusion_;
  std::unique_ptr<VideoSink> video_;
  std::unique_ptr<ViewerWindow> viewer_;
  std::chrono::steady_clock::time_point last_view_post_ = std::chrono::steady_clock::now () - std::chrono::seconds (10);
  RunOutputs result_;
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
  if (!s.masks.empty ())
    return std::make_shared<recognition::MaskFolderSegmenter> (s.masks);
  if (!s.onnx.model_path.empty ())
    return std::make_shared<recognition::OnnxInstanceSegmenter> (s.onnx);
  return nullptr;
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
RunSession::masksFor (const RGBDFrame& frame, std::vector<Instance>& instances, recognition::PreparedFrame* masks_ahead)
{
  if (!mask_source_ || pipeline_config_.mode == pipeline::SegmentationMode::Geometry)
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
  }
  else
  {
    const auto t0 = std::chrono::steady_clock::now ();
    have_masks = mask_source_->segment (frame, instances);
    result_.masks_ms.push_back (std::chrono::duration<double, std::milli> (std::chrono::steady_clock::now () - t0).count ());
    result_.masks_stages.push_back (mask_source_->lastTimings ());
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
    const bool have_masks = masksFor (*frame, instances, masks_ahead);
    const pipeline::PipelineFrameReport full = fusion_.process (*frame, have_masks ? &instances : nullptr);
    reconstruction::FrameReport report = full.reconstruction;
    if (full.segmented)
    {
      result_.segmentation.push_back (full.segmentation);
      const reconstruction::StageTimings& t = full.reconstruction.timings;
      result_.loop_ms.push_back (t.preprocess_ms + t.track_ms + t.integrate_ms + t.raycast_ms + full.segmentation.total ());
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
  const bool masks_ahead = mask_source_ && !asynchronous_masks_ && pipeline_config_.mode != pipeline::SegmentationMode::Geometry;
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
  const reconstruction::TSDFVolume& volume = fusion_.reconstruction ().volume ();
  nlohmann::json tracking;
  nlohmann::json lost = nlohmann::json::array ();
  for (const auto& r : result_.reports)
    if (!r.tracked)
      lost.push_back ({{"index", r.index}, {"timestamp", r.timestamp}, {"reason", r.failure}});
  nlohmann::json relocalised = nlohmann::json::array ();
  for (const auto& r : result_.reports)
    if (r.relocalised)
      relocalised.push_back ({{"index", r.index}, {"timestamp", r.timestamp}, {"from", r.relocalised_from},
                              {"ms", r.timings.relocalise_ms}});
  lost_ = lost.size ();
  relocalised_ = relocalised.size ();
  tracking["frames"] = result_.reports.size ();
  tracking["tracked"] = result_.trajectory.size ();
  tracking["lost"] = lost;
  tracking["relocalised"] = relocalised;
  tracking["mode"] = s_.pipeline.reconstruction.use_reference_poses ? "reference poses" : "frame-to-model ICP";
  tracking["segmentation"] = {{"mode", pipeline::segmentationModeName (pipeline_config_.mode)},
                              {"mask_source", mask_source_ ? mask_source_->name () : std::string ()},
                              {"frames_without_masks", result_.frames_without_masks},
                              {"merges", result_.merges},
                              {"noise_scale", fusion_.noiseScale ()}};
  tracking["volume"] = {{"blocks", volume.blockCount ()}, {"bytes", volume.memoryUsage ()},
                        {"voxel_size", volume.getConfig ().voxel_size}, {"truncation_voxels", volume.getConfig ().truncation_voxels}};
  if (!s_.load_volume.empty ())
    tracking["continued_from"] = s_.load_volume;
  if (!s_.pipeline.reconstruction.use_reference_poses && result_.reference.size () >= 3 && result_.trajectory.size () >= 3)
  {
    const evaluation::TrajectoryError ate = evaluation::absoluteTrajectoryError (result_.trajectory, result_.reference, 1e-4);
    tracking["ate"] = {{"rmse", ate.rmse}, {"mean", ate.mean}, {"median", ate.median}, {"max", ate.max}, {"pairs", ate.pairs}};
    std::ostringstream line;
    line << std::fixed << std::setprecision (4) << "  ATE RMSE:   " << ate.rmse << " m against the sequence's poses ("
         << ate.pairs << " frames)\n";
    ate_line_ = line.str ();
  }
  return tracking;
}

nlohmann::json
RunSession::withProvenance (nlohmann::json manifest) const
{
  // What ran, to repeat it: the arguments as given (`cuefusion run` then these repeats the
  // run exactly: offline runs are frame-exact), the working folder they are relative to,
  // and the network by its bytes.
  nlohmann::json arguments = nlohmann::json::array ({"run"});
  for (const std::string& a : s_.command_line)
    arguments.push_back (a);
  manifest["command_line"] = arguments;
  manifest["working_directory"] = fs::current_path ().string ();
  // The settings as one settings file: `run SEQUENCE --config outputs.json` uses them.
  manifest["config"] = runConfigJson (s_);
  if (!s_.onnx.model_path.empty ())
  {
    const std::string model = findDataFile (s_.onnx.model_path, "models", ".onnx");
    manifest["model"] = {{"path", fs::absolute (model).string ()}, {"sha256", io::sha256OfFile (model)}};
  }
  return manifest;
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
                       io::jsonText (timingsJson (result_, seconds_), 2) + "\n");
  nlohmann::json files = nlohmann::json::array ();
  for (const std::string& name : kRunOutputs)
    if (fs::exists (fs::path (outputs_.stagingPath (name))))
      files.push_back (name);
  const nlohmann::json manifest = {{"command", "run"},
                                   {"version", version ()},
                                   {"sequence", s_.source},
                                   {"frames", result_.reports.size ()},
                                   {"seconds", seconds_},  // processing, opening the sequence to the last frame
                                   {"complete", true},
                                   // a recorded sequence cut short by a signal or a closed window
                                   {"stopped_early", dataset_ != nullptr && InterruptHandlers::interrupted ()},
                                   {"files", files}};
  io::writeTextAtomic (staged ("outputs.json"), io::jsonText (withProvenance (manifest), 2) + "\n");
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
