// SPDX-License-Identifier: BSD-3-Clause
// `cuefusion run`'s settings (also `batch`'s, which forwards them): the options, the
// settings file (--config), their checks and the pipeline's Config they make.
#include "cli.h"
#include "option_fields.h"

#include <cuefusion/common/exceptions.h>
#include <cuefusion/io/sequence.h>
#include <cuefusion/pipeline/settings.h>
#include <cuefusion/recognition/periodic_segmenter.h>
#include <cuefusion/recognition/settings.h>

#include <boost/filesystem.hpp>
#include <nlohmann/json.hpp>

#include <sstream>

namespace cuefusion
{
namespace cli
{
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
    (boundOption ("TSDFVolumeConfig::voxel_size"), po::value (&r.volume.voxel_size)->default_value (r.volume.voxel_size), "TSDF voxel size in metres")
    (boundOption ("TSDFVolumeConfig::truncation_voxels"), po::value (&r.volume.truncation_voxels)->default_value (r.volume.truncation_voxels), "TSDF truncation distance in voxels (times the depth noise scale when above 1: see --noise-scale)")
    (boundOption ("TSDFVolumeConfig::max_depth"), po::value<double> ()->notifier ([&r] (double d) { r.volume.max_depth = r.preprocessing.max_depth = d; }),
     withDefault ("ignore depth beyond this (metres)", r.volume.max_depth).c_str ())
    ("use-gt-poses", setsWhenGiven (r.use_reference_poses, true), "integrate with the sequence's own poses instead of tracking")
    ("no-motion-model", setsWhenGiven (r.motion_model, false), "tracking: start ICP at the last pose instead of the constant-velocity prediction")
    ("no-features", setsWhenGiven (r.feature_relocalisation, false), "relocalisation: no colour features (keyframes and the motion model only)")
    ("no-noise-weighting", setsWhenGiven (r.tracking.icp.noise_weighting, false), "tracking: every ICP term counts the same, instead of by the inverse depth-noise variance")
    (boundOption ("DenseReconstructionConfig::hole_refresh_period"), po::value (&r.hole_refresh_period)->default_value (r.hole_refresh_period), "raycast: rays behind depth holes that found no surface are searched again every N frames (1 = every frame)")
    ("colors", po::value (&s.colors), "colour map.pcd and mesh.ply alike: segments (each segment its label's colour, none grey) or "
     "surface (the fused colour); without it map.pcd has the surface colour and mesh.ply the segments'")
    ("export-objects", po::bool_switch (&s.export_objects), "also write each object's part of the mesh as objects/ID.ply (ID as in segments.json, which gives every segment's centroid and oriented box)")
    ("save-volume", po::bool_switch (&s.save_volume), "also write the TSDF volume (volume.tsdf), its voxels' labels as map.pcd's (volume.labels) and the relocalisation keyframes (volume.keyframes)")
    ("load-volume", po::value (&s.load_volume), "continue a saved volume.tsdf (with the volume.labels and volume.keyframes beside it): the first frame is relocalised in it, its objects are kept")
    ("mode", po::value (&s.mode), "fused (geometry grouped by instance masks; the default with --masks/--model), geometry, or masks")
    (boundOption ("GeometricSegmentationConfig::noise_scale"), po::value (&s.pipeline.geometry.noise_scale)->default_value (s.pipeline.geometry.noise_scale),
     "the depth's noise as a multiple of the Kinect model's, which scales every noise threshold (0 = measured on the first frames)")
    (boundOption ("InstanceGuidedRegionMergeConfig::color_split_distance"), po::value (&s.pipeline.instance_merge.color_split_distance)->default_value (s.pipeline.instance_merge.color_split_distance),
     "fused: a mask is cut between the segments it claims whose colours lie this far apart (rg chromaticity; 0 = never)")
    ("masks", po::value (&s.masks), "folder of per-frame 16-bit instance-id PNGs (+ JSON), matched by frame name or index")
    ("model", po::value (&s.onnx.model_path), "instance masks from an ONNX model (OpenCV DNN, CPU): cuefusion's depth network by name, "
     "xyz_instances (found in the data directory from any folder), or the path of an .onnx file such as a YOLO-seg export run on the colour image")
    ("classes", po::value (&s.onnx.classes_path), "class names of --model (default data/classes/coco.names)")
    (boundOption ("OnnxInstanceSegmenterConfig::input_size"), po::value (&s.onnx.input_size)->default_value (s.onnx.input_size), "network input size of --model (px)")
    (boundOption ("OnnxInstanceSegmenterConfig::score_threshold"), po::value (&s.onnx.score_threshold)->default_value (s.onnx.score_threshold), "--model detections below are dropped")
    (boundOption ("OnnxInstanceSegmenterConfig::boundary_threshold"), po::value (&s.onnx.boundary_threshold)->default_value (s.onnx.boundary_threshold),
     "--model of the xyz layout: instances are cut where the boundary probability reaches this")
    (boundOption ("PeriodicSegmenter::period"), po::value (&s.masks_every)->default_value (s.masks_every),
     "run the mask source on every N-th frame only; the frames between use the masks of the last frame it ran on, carried by the camera's motion (as a live camera does, but repeatable; 1 = every frame)")
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
  recognition::PeriodicSegmenter::checkPeriod (s.masks_every);  // named by its field, as the library's checks below
  if (s.masks_every > 1 && s.masks.empty () && s.onnx.model_path.empty ())
    throw UsageError ("--masks-every needs --masks or --model");
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
}  // namespace cli
}  // namespace cuefusion
