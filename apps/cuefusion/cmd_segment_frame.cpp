// SPDX-License-Identifier: BSD-3-Clause
// cuefusion segment-frame: the geometric segmentation L^G (§4.2.1.1) of single organized
// clouds or depth images, as a PCL filter chain: SurfacePreprocessing →
// GeometricSegmentation → (SupportPlaneRemoval).
#include "cli.h"
#include "option_fields.h"

#include <cuefusion/common/exceptions.h>
#include <cuefusion/common/label_colors.h>
#include <cuefusion/io/camera_io.h>
#include <cuefusion/io/file_io.h>
#include <cuefusion/io/map_io.h>
#include <cuefusion/common/instance.h>
#include <cuefusion/pipeline/fusion_pipeline.h>
#include <cuefusion/pipeline/frame_segmentation.h>
#include <cuefusion/pipeline/run_files.h>
#include <cuefusion/pipeline/settings.h>
#include <cuefusion/recognition/settings.h>
#include <cuefusion/recognition/mask_folder_segmenter.h>
#include <cuefusion/recognition/onnx_instance_segmenter.h>
#include <cuefusion/segmentation/geometric_segmentation.h>
#include <cuefusion/segmentation/instance_guided_region_merge.h>
#include <cuefusion/segmentation/support_plane_removal.h>
#include <cuefusion/segmentation/surface_preprocessing.h>

#include <boost/filesystem.hpp>
#include <nlohmann/json.hpp>

#include <opencv2/imgcodecs.hpp>

#include <pcl/PCLPointCloud2.h>
#include <pcl/common/time.h>
#include <pcl/conversions.h>
#include <pcl/io/pcd_io.h>

#include <algorithm>
#include <cmath>
#include <iomanip>
#include <iostream>
#include <limits>
#include <map>
#include <memory>
#include <optional>
#include <set>

namespace fs = boost::filesystem;

namespace cuefusion
{
namespace cli
{
namespace
{
using Cloud = pcl::PointCloud<pcl::PointXYZRGBA>;

using io::hasField;

/** An organized PCD with at least x, y, z (colour from rgb/rgba when present). */
Cloud::Ptr
loadOrganizedPCD (const std::string& path)
{
  const pcl::PCLPointCloud2 blob = io::readPCD (path);
  if (blob.height < 2 || blob.width * blob.height == 0)
    throw Error (path, "PCD is not organized (height " + std::to_string (blob.height) + "); segment-frame needs an image-shaped cloud");
  Cloud::Ptr cloud = pcl::make_shared<Cloud> ();
  pcl::fromPCLPointCloud2 (blob, *cloud);
  if (!hasField (blob, "rgb") && !hasField (blob, "rgba"))
    for (auto& p : cloud->points)
      p.r = p.g = p.b = p.a = 255;
  return cloud;
}

/** A 16-bit depth PNG back-projected with \a camera, coloured from \a rgb_path when given. */
Cloud::Ptr
loadDepthPNG (const std::string& path, const PinholeCamera& camera, double units_per_metre, const std::string& rgb_path)
{
  const cv::Mat depth = io::readDepthImage (path, units_per_metre);
  if (depth.cols != camera.width || depth.rows != camera.height)
    throw Error (path, "depth image is " + std::to_string (depth.cols) + "x" + std::to_string (depth.rows) +
                         " but the intrinsics are for " + std::to_string (camera.width) + "x" + std::to_string (camera.height));
  cv::Mat color;
  if (!rgb_path.empty ())
  {
    color = io::readImage (rgb_path, cv::IMREAD_COLOR);
    if (color.size () != depth.size ())
      throw Error (rgb_path, "colour image size differs from the depth image's");
  }
  Cloud::Ptr cloud = pcl::make_shared<Cloud> (depth.cols, depth.rows);
  const float nan = std::numeric_limits<float>::quiet_NaN ();
  for (int y = 0; y < depth.rows; ++y)
    for (int x = 0; x < depth.cols; ++x)
    {
      pcl::PointXYZRGBA& p = (*cloud) (x, y);
      const float z = depth.at<float> (y, x);
      if (z > 0.f)
      {
        p.x = static_cast<float> ((x - camera.cx) / camera.fx) * z;
        p.y = static_cast<float> ((y - camera.cy) / camera.fy) * z;
        p.z = z;
      }
      else
        p.x = p.y = p.z = nan;
      if (color.empty ())
        p.r = p.g = p.b = 255;
      else
      {
        const cv::Vec3b bgr = color.at<cv::Vec3b> (y, x);
        p.r = bgr[2];
        p.g = bgr[1];
        p.b = bgr[0];
      }
      p.a = 255;
    }
  cloud->is_dense = false;
  return cloud;
}

/** Colour image of a cloud loaded from PCD, replacing its colours (PCD input with --rgb). */
void
applyColorImage (const std::string& rgb_path, Cloud& cloud)
{
  const cv::Mat color = io::readImage (rgb_path, cv::IMREAD_COLOR);
  if (color.cols != static_cast<int> (cloud.width) || color.rows != static_cast<int> (cloud.height))
    throw Error (rgb_path, "colour image size differs from the cloud's " + std::to_string (cloud.width) + "x" +
                             std::to_string (cloud.height));
  for (int y = 0; y < color.rows; ++y)
    for (int x = 0; x < color.cols; ++x)
    {
      const cv::Vec3b bgr = color.at<cv::Vec3b> (y, x);
      auto& p = cloud (x, y);
      p.r = bgr[2];
      p.g = bgr[1];
      p.b = bgr[0];
    }
}

/** Thesis Fig. 4.9 (top) as one picture: concave edges red, depth edges green, both
  * yellow, no depth grey. */
cv::Mat
edgePicture (const cv::Mat& concavity, const cv::Mat& discontinuity, const Cloud& cloud)
{
  cv::Mat picture (concavity.size (), CV_8UC3, cv::Scalar (0, 0, 0));
  for (int y = 0; y < picture.rows; ++y)
    for (int x = 0; x < picture.cols; ++x)
    {
      cv::Vec3b& bgr = picture.at<cv::Vec3b> (y, x);
      if (!std::isfinite (cloud (x, y).z))
        bgr = cv::Vec3b (80, 80, 80);
      if (concavity.at<std::uint8_t> (y, x))
        bgr[2] = 255;
      if (discontinuity.at<std::uint8_t> (y, x))
        bgr[1] = 255;
    }
  return picture;
}

/** What each label of the output is: its instance's class and score, or geometry only. */
std::string
segmentsJson (const std::vector<segmentation::SegmentInstance>& segments, const cv::Mat& labels)
{
  std::vector<int> pixels (segments.size (), 0);
  for (int y = 0; y < labels.rows; ++y)
    for (int x = 0; x < labels.cols; ++x)
    {
      const int label = labels.at<std::int32_t> (y, x);
      if (label > 0 && static_cast<std::size_t> (label) < pixels.size ())
        ++pixels[static_cast<std::size_t> (label)];
    }
  nlohmann::json list = nlohmann::json::array ();
  for (std::size_t label = 1; label < segments.size (); ++label)
  {
    if (pixels[label] == 0)
      continue;  // dropped with the support plane, or hidden by an overlapping mask
    const auto& s = segments[label];
    nlohmann::json entry = {{"label", label}, {"pixels", pixels[label]}};
    if (s.instance >= 0)
      entry.update ({{"class_id", s.class_id}, {"class_name", s.class_name}, {"score", s.score}});
    if (s.geometric_segments > 0)
      entry["geometric_segments"] = s.geometric_segments;
    list.push_back (entry);
  }
  return io::jsonText (nlohmann::json ({{"segments", list}}), 1) + "\n";
}

struct FrameTimes
{
  double load_ms = 0, smoothing_ms = 0, normals_ms = 0, edges_ms = 0, labeling_ms = 0, masks_ms = 0,
         plane_ms = 0, write_ms = 0;
  double segmentation () const { return smoothing_ms + normals_ms + edges_ms + labeling_ms; }
};


/** In folder mode a companion file (--rgb) for \a input: same stem, any image extension. */
std::string
companionImage (const std::string& folder, const std::string& input)
{
  const std::string stem = fs::path (input).stem ().string ();
  for (const char* ext : {".png", ".jpg", ".jpeg", ".ppm"})
  {
    const fs::path candidate = fs::path (folder) / (stem + ext);
    if (fs::exists (candidate))
      return candidate.string ();
  }
  throw Error (folder, "no colour image named " + stem + ".png/.jpg for " + input);
}
/** segment-frame's options, checked (parseSegmentFrameSettings). */
struct SegmentFrameSettings
{
  std::string input, out, intrinsics_path, rgb, png, edges_png, timings_path, masks, mode;
  recognition::OnnxInstanceSegmenterConfig onnx;
  segmentation::InstanceGuidedRegionMergeConfig merge;
  double depth_scale = 1000.0;
  bool drop_plane = false, verbose = false;
  segmentation::GeometricSegmentationConfig geo;
  segmentation::SupportPlaneRemovalConfig plane;
};

/** Folder mode's outputs: each output folder (--out, --png, --edges-png; one when two
  * name the same) is one io::OutputSet, so that an error at any frame leaves every folder
  * as it was, and a completed call replaces the previous call's files of these inputs as
  * a whole. Each input writes STEM.pcd (+ STEM.json) and STEM.png; two inputs of one stem
  * (a.pcd and a.png) would overwrite each other's outputs and are refused. */
class FolderOutputs
{
public:
  FolderOutputs (const SegmentFrameSettings& s, const std::vector<std::string>& inputs)
  {
    std::map<std::string, std::string> stems;  // stem → input
    for (const std::string& input : inputs)
    {
      const auto [it, fresh] = stems.emplace (fs::path (input).stem ().string (), input);
      if (!fresh)
        throw Error (input, "has the stem of " + fs::path (it->second).filename ().string () +
                                ": both would write the same output files");
    }
    const std::string last = fs::path (inputs.back ()).stem ().string ();
    std::map<std::string, std::pair<std::vector<std::string>, std::string>> wanted;  // folder → owned names, marker
    const auto want = [&] (const std::string& folder, const std::vector<std::string>& extensions) {
      if (folder.empty ())
        return;
      auto& [owned, marker] = wanted[key (folder)];
      for (const auto& stem : stems)
        for (const std::string& extension : extensions)
          owned.push_back (stem.first + extension);
      if (marker.empty ())
        marker = last + extensions.front ();  // the last input's first output: written last
    };
    want (s.out, {".pcd", ".json"});
    want (s.png, {".png"});
    want (s.edges_png, {".png"});
    for (auto& [folder, names] : wanted)
      sets_.emplace (folder, std::make_unique<io::OutputSet> (folder, names.first, names.second));
  }

  /** Where \a input's output of \a extension for the folder \a folder goes now (staged). */
  std::string
  path (const std::string& folder, const std::string& input, const std::string& extension) const
  {
    return sets_.at (key (folder))->stagingPath (fs::path (input).stem ().string () + extension);
  }

  void
  commit ()
  {
    for (auto& [folder, set] : sets_)
      set->commit ();
  }

private:
  static std::string
  key (const std::string& folder)
  {
    // Absolute first: Boost's weakly_canonical leaves a relative path whose first
    // element does not exist yet as it is, so "out" would not find itself once created.
    boost::system::error_code ec;
    const fs::path canonical = fs::weakly_canonical (fs::absolute (folder), ec);
    return ec ? folder : canonical.string ();
  }

  std::map<std::string, std::unique_ptr<io::OutputSet>> sets_;
};

/** segment-frame's settings as one settings file. */
nlohmann::json
segmentFrameConfigJson (const SegmentFrameSettings& s)
{
  return {{"geometry", pipeline::configJson (s.geo)},
          {"instance_merge", pipeline::configJson (s.merge)},
          {"support_plane", pipeline::configJson (s.plane)},
          {"network", recognition::configJson (s.onnx)}};
}

/** --config FILE of \a args into \a s, before the options take their defaults from it. */
void
loadSegmentFrameConfig (const std::vector<std::string>& args, SegmentFrameSettings& s)
{
  readConfigParts ("segment-frame", args,
                   {{"geometry", [&s] (const nlohmann::json& part) { pipeline::readConfig (part, s.geo); }},
                    {"instance_merge", [&s] (const nlohmann::json& part) { pipeline::readConfig (part, s.merge); }},
                    {"support_plane", [&s] (const nlohmann::json& part) { pipeline::readConfig (part, s.plane); }},
                    {"network", [&s] (const nlohmann::json& part) { recognition::readConfig (part, s.onnx); }}});
}

/** Parses and checks segment-frame's command line; false when --help or --print-config
  * was given (the settings printed). */
bool
parseSegmentFrameSettings (const std::vector<std::string>& args, SegmentFrameSettings& s)
{
  loadSegmentFrameConfig (args, s);
  segmentation::SurfacePreprocessingConfig& pre = s.geo.preprocessing;  // the library's own default, one source
  segmentation::GeometricSegmentationConfig& geo = s.geo;
  std::string normals = pre.normal_method == segmentation::NormalMethod::IntegralImage ? "integral" : "central";
  std::string convexity = geo.concavity.convexity_test == segmentation::ConvexityTest::TangentPlane ? "tangent" : "divergence";
  bool print_config = false;
  po::options_description options ("options");
  options.add_options ()
    ("input", po::value (&s.input), "organized PCD, 16-bit depth PNG, or a folder of them")
    ("out", po::value (&s.out), "output PCD (PointXYZRGBL, organized; label 0 = no segment), or a folder for folder input")
    ("config", po::value<std::string> (), "settings file (JSON: \"geometry\", \"instance_merge\", \"support_plane\", \"network\"; "
     "the library's Config fields by name, see --print-config); options given on the command line override it")
    ("print-config", po::bool_switch (&print_config), "print the settings this call would use as a settings file, and stop")
    ("intrinsics", po::value (&s.intrinsics_path), "intrinsics file for depth PNG input (JSON, 3x3/4x4 matrix or a line)")
    ("depth-scale", po::value (&s.depth_scale)->default_value (1000.0), "depth PNG units per metre (TUM: 5000)")
    ("rgb", po::value (&s.rgb), "colour image for the output's colours (a folder for folder input: same stems)")
    ("png", po::value (&s.png), "also write a colour-coded label PNG (a folder for folder input)")
    ("edges-png", po::value (&s.edges_png), "also write the edge maps (red concave, green depth edges, grey no depth; a folder for folder input)")
    ("masks", po::value (&s.masks), "instance masks: a 16-bit id PNG (+ JSON of the same stem), or for folder input a folder of them matched by file stem")
    ("model", po::value (&s.onnx.model_path), "instance masks from an ONNX model (OpenCV DNN, CPU): cuefusion's depth network by name, "
     "xyz_instances (found in the data directory from any folder), or the path of an .onnx file such as a YOLO-seg export run on the colour image")
    ("classes", po::value (&s.onnx.classes_path), "class names of --model, one per line (default data/classes/coco.names)")
    (boundOption ("OnnxInstanceSegmenterConfig::input_size"), po::value (&s.onnx.input_size)->default_value (s.onnx.input_size), "network input size of --model (px)")
    (boundOption ("OnnxInstanceSegmenterConfig::score_threshold"), po::value (&s.onnx.score_threshold)->default_value (s.onnx.score_threshold), "--model detections below are dropped")
    (boundOption ("OnnxInstanceSegmenterConfig::boundary_threshold"), po::value (&s.onnx.boundary_threshold)->default_value (s.onnx.boundary_threshold),
     "--model of the xyz layout: instances are cut where the boundary probability reaches this")
    ("mode", po::value (&s.mode), "geometry (L^G), masks (instance masks only) or fused (InstanceGuidedRegionMerge, the default with --masks/--model)")
    (boundOption ("InstanceGuidedRegionMergeConfig::min_overlap"), po::value (&s.merge.min_overlap)->default_value (s.merge.min_overlap), "fused: share of a geometric segment inside one instance to join it")
    (boundOption ("InstanceGuidedRegionMergeConfig::color_split_distance"), po::value (&s.merge.color_split_distance)->default_value (s.merge.color_split_distance),
     "fused: a mask is cut between the segments it claims whose colours lie this far apart (rg chromaticity; 0 = never)")
    ("drop-support-plane", po::bool_switch (&s.drop_plane), "label the dominant plane (table, floor) 0")
    ("verbose,v", po::bool_switch (&s.verbose), "print per-stage timings per frame")
    ("timings", po::value (&s.timings_path), "write per-frame stage timings (ms) to this JSON file")
    ("normals", po::value (&normals)->default_value (normals), "normal estimation: central (differences, §4.1.2) or integral (PCL integral image)")
    (boundOption ("SurfacePreprocessingConfig::bilateral.noise_range_sigma"), po::value (&pre.bilateral.noise_range_sigma)->default_value (pre.bilateral.noise_range_sigma), "bilateral range sigma in units of the sensor noise sigma_z(z)")
    (boundOption ("SurfacePreprocessingConfig::bilateral.sigma_space"), po::value (&pre.bilateral.sigma_space)->default_value (pre.bilateral.sigma_space), "bilateral spatial sigma (px)")
    (boundOption ("SurfacePreprocessingConfig::bilateral.diameter"), po::value (&pre.bilateral.diameter)->default_value (pre.bilateral.diameter), "bilateral window (px)")
    ("no-bilateral", "switch the bilateral filter off")
    (boundOption ("SurfacePreprocessingConfig::normals.step"), po::value (&pre.normals.step)->default_value (pre.normals.step), "central differences over +-N px")
    (boundOption ("SurfacePreprocessingConfig::integral_smoothing"), po::value (&pre.integral_smoothing)->default_value (pre.integral_smoothing), "integral-image normal smoothing size (px)")
    (boundOption ("EdgeLabelingConfig::max_depth_jump"), po::value (&pre.normals.max_depth_jump)->default_value (pre.normals.max_depth_jump), "relative depth step treated as an edge by normals and edge assignment")
    (boundOption ("ConcavityEdgeEstimationConfig::threshold"), po::value (&geo.concavity.threshold)->default_value (geo.concavity.threshold), "concave edge where Phi < this")
    (boundOption ("ConcavityEdgeEstimationConfig::noise_slope"), po::value (&geo.concavity.noise_slope)->default_value (geo.concavity.noise_slope),
     "the concavity threshold gives way to the normals' noise: cos of this x sigma_z(z)/z where lower (0 = off)")
    ("convexity-test", po::value (&convexity)->default_value (convexity), "when a neighbour is convex: divergence (normals turn apart) or tangent (thesis: below the tangent plane)")
    (boundOption ("ConcavityEdgeEstimationConfig::neighbour_step"), po::value (&geo.concavity.neighbour_step)->default_value (geo.concavity.neighbour_step), "concavity neighbour distance (px)")
    (boundOption ("GeometricSegmentationConfig::noise_scale"), po::value (&geo.noise_scale)->default_value (geo.noise_scale),
     "the depth's noise as a multiple of the Kinect model's, which scales every noise threshold (0 = measured per frame)")
    (boundOption ("DepthDiscontinuityEdgeEstimationConfig::noise_factor"), po::value (&geo.discontinuity.noise_factor)->default_value (geo.discontinuity.noise_factor), "depth edge where Gamma > k * sigma_d")
    (boundOption ("DepthDiscontinuityEdgeEstimationConfig::neighbour_step"), po::value (&geo.discontinuity.neighbour_step)->default_value (geo.discontinuity.neighbour_step), "depth-edge neighbour distance (px)")
    ("no-concavity", setsWhenGiven (geo.use_concavity_edges, false), "ablation: no concavity edges")
    ("no-depth-edges", setsWhenGiven (geo.use_discontinuity_edges, false), "ablation: no depth-discontinuity edges")
    (boundOption ("EdgeLabelingConfig::closing_iterations"), po::value (&geo.labeling.closing_iterations)->default_value (geo.labeling.closing_iterations), "closing iterations of the edge map (0 = off)")
    (boundOption ("EdgeLabelingConfig::min_segment_size"), po::value (&geo.labeling.min_segment_size)->default_value (geo.labeling.min_segment_size), "smaller segments get label 0 (px)")
    (boundOption ("EdgeLabelingConfig::edge_assignment_radius"), po::value (&geo.labeling.edge_assignment_radius)->default_value (geo.labeling.edge_assignment_radius), "give edge pixels to the adjacent segment up to N px out (0 = off)")
    (boundOption ("SupportPlaneRemovalConfig::distance_threshold"), po::value (&s.plane.distance_threshold)->default_value (s.plane.distance_threshold), "support plane inlier band (m)");
  po::positional_options_description positional;
  positional.add ("input", 1);
  po::variables_map vm;
  if (!parseCommandLine ("segment-frame", "INPUT --out OUT.pcd [options]", args, options, positional, vm))
    return false;

  if (normals == "central")
    pre.normal_method = segmentation::NormalMethod::CentralDifference;
  else if (normals == "integral")
    pre.normal_method = segmentation::NormalMethod::IntegralImage;
  else
    throw ParameterError ("--normals", "must be central or integral, not '" + normals + "'");
  if (convexity == "divergence")
    geo.concavity.convexity_test = segmentation::ConvexityTest::NormalDivergence;
  else if (convexity == "tangent")
    geo.concavity.convexity_test = segmentation::ConvexityTest::TangentPlane;
  else
    throw ParameterError ("--convexity-test", "must be divergence or tangent, not '" + convexity + "'");
  if (vm.count ("no-bilateral"))
    pre.bilateral.enabled = false;
  if (!(s.depth_scale > 0.0) || !std::isfinite (s.depth_scale))
    throw ParameterError ("--depth-scale", "must be a positive number");
  if (given (vm, "max-depth-jump"))  // one option for both (a settings file may set them apart)
    geo.labeling.max_depth_jump = pre.normals.max_depth_jump;
  pre.validate ();
  geo.validate ();
  s.plane.validate ();
  s.merge.validate ();
  s.mode = pipeline::segmentationModeName (chooseSegmentationMode (s.mode, s.masks, s.onnx.model_path));
  if (print_config)
  {
    std::cout << io::jsonText (segmentFrameConfigJson (s), 2) << "\n";
    return false;
  }
  for (const char* required : {"input", "out"})  // not needed to print the settings
    if (!vm.count (required))
      throw UsageError (std::string ("the option '--") + required + "' is required but missing");
  return true;
}

/** The library's single-frame segmentation with the options' Configs and mode. */
pipeline::FrameSegmentationConfig
frameSegmentationConfig (const SegmentFrameSettings& s)
{
  pipeline::FrameSegmentationConfig config;
  config.geometry = s.geo;
  config.instance_merge = s.merge;
  config.mode = pipeline::parseSegmentationMode (s.mode);
  return config;
}

/** Segments one input after another with the same objects (the fast path: smoothed
  * points and normals stay in SurfacePlanes, reused from frame to frame, without copies
  * into PCL clouds; the PCL-typed interface gives the same labels). */
class FrameSegmenter
{
public:
  /** \a outputs: folder mode's output sets (nullptr for a single input). */
  FrameSegmenter (const SegmentFrameSettings& s, const FolderOutputs* outputs);

  /** Segments \a path (input number \a index) and writes its outputs; its report entry. */
  nlohmann::json segment (const std::string& path, std::size_t index, double& segmentation_ms);

private:
  Cloud::Ptr load (const std::string& path, FrameTimes& t) const;
  /** The masks' word on \a label_image (fused or masks mode); fills \a segments. */
  cv::Mat applyMasks (const std::string& path, std::size_t index, const Cloud& cloud, cv::Mat label_image,
                      std::vector<segmentation::SegmentInstance>& segments);
  void write (const std::string& path, const Cloud& cloud, const cv::Mat& label_image,
              const std::vector<segmentation::SegmentInstance>& segments) const;

  /** Where \a input's output of \a extension for the option's value \a given goes. */
  std::string
  outputPath (const std::string& given, const std::string& input, const std::string& extension) const
  {
    return outputs_ ? outputs_->path (given, input, extension) : given;
  }

  const SegmentFrameSettings& s_;
  const FolderOutputs* outputs_;
  const bool folder_;
  std::unique_ptr<recognition::InstanceSegmenter> source_;
  std::optional<PinholeCamera> camera_;
  bool warned_missing_ = false;
  pipeline::FrameSegmentation frame_;  ///< smoothed points and normals reused from input to input
  segmentation::SupportPlaneRemoval<pcl::PointXYZRGBA> plane_removal_;
};

FrameSegmenter::FrameSegmenter (const SegmentFrameSettings& s, const FolderOutputs* outputs)
  : s_ (s), outputs_ (outputs), folder_ (outputs != nullptr), frame_ (frameSegmentationConfig (s)), plane_removal_ (s.plane)
{
  boost::system::error_code ec;
  if (!s.masks.empty ())
  {
    if (folder_ != fs::is_directory (s.masks, ec))
      throw Error (s.masks, folder_ ? "folder input needs a folder of masks" : "a single input needs a single mask PNG");
    if (folder_)
      source_ = std::make_unique<recognition::MaskFolderSegmenter> (s.masks);
  }
  else if (!s.onnx.model_path.empty ())
    source_ = std::make_unique<recognition::OnnxInstanceSegmenter> (s.onnx);
  if (!s.intrinsics_path.empty ())
    camera_ = io::readIntrinsics (s.intrinsics_path);
}

Cloud::Ptr
FrameSegmenter::load (const std::string& path, FrameTimes& t) const
{
  pcl::StopWatch watch;
  std::string extension = fs::path (path).extension ().string ();
  std::transform (extension.begin (), extension.end (), extension.begin (), ::tolower);
  const std::string rgb_path = s_.rgb.empty () ? "" : (folder_ ? companionImage (s_.rgb, path) : s_.rgb);
  Cloud::Ptr cloud;
  if (extension == ".png")
  {
    if (!camera_)
      throw UsageError ("depth PNG input " + path + " needs --intrinsics");
    cloud = loadDepthPNG (path, *camera_, s_.depth_scale, rgb_path);
  }
  else
  {
    cloud = loadOrganizedPCD (path);
    if (!rgb_path.empty ())
      applyColorImage (rgb_path, *cloud);
  }
  t.load_ms = watch.getTime ();
  return cloud;
}

cv::Mat
FrameSegmenter::applyMasks (const std::string& path, std::size_t index, const Cloud& cloud, cv::Mat label_image,
                            std::vector<segmentation::SegmentInstance>& segments)
{
  std::vector<Instance> instances;
  bool have_masks = true;
  RGBDFrame frame = fromOrganizedCloud (cloud);  // the xyz network needs depth and a camera; the merge, colour
  if (!source_)
    instances = recognition::MaskFolderSegmenter::readInstanceMasks (s_.masks, label_image.size ());
  else
  {
    frame.index = index;
    frame.name = fs::path (path).stem ().string ();
    have_masks = source_->segment (frame, instances);
  }
  if (!have_masks && !warned_missing_)
  {
    std::cerr << "segment-frame: no masks for " << path << " (nor, maybe, for later inputs): geometry only there\n";
    warned_missing_ = true;
  }
  if (!have_masks)
    return label_image;
  return frame_.applyMasks (instances, frame.color, &segments);
}

void
FrameSegmenter::write (const std::string& path, const Cloud& cloud, const cv::Mat& label_image,
                       const std::vector<segmentation::SegmentInstance>& segments) const
{
  pcl::PointCloud<pcl::PointXYZRGBL> labelled;
  segmentation::toLabelledCloud (cloud, label_image, labelled);  // original, unsmoothed points
  if (!s_.png.empty ())
    io::writeImageAtomic (outputPath (s_.png, path, ".png"), colorizeLabels (label_image));
  if (!segments.empty ())
    io::writeTextAtomic (folder_ ? outputPath (s_.out, path, ".json") : fs::path (s_.out).replace_extension (".json").string (),
                         segmentsJson (segments, label_image));
  if (!s_.edges_png.empty ())
    io::writeImageAtomic (outputPath (s_.edges_png, path, ".png"),
                          edgePicture (frame_.geometricSegmentation ().getConcavityEdges (), frame_.geometricSegmentation ().getDiscontinuityEdges (), cloud));
  io::saveMapPCD (outputPath (s_.out, path, ".pcd"), labelled);  // last: in folder mode the last input's is the set's marker
}

nlohmann::json
FrameSegmenter::segment (const std::string& path, std::size_t index, double& segmentation_ms)
{
  FrameTimes t;
  const Cloud::Ptr cloud = load (path, t);
  try
  {
    frame_.segmentGeometry (cloud);
    t.smoothing_ms = frame_.smoothingTime ();
    t.normals_ms = frame_.normalTime ();
  }
  catch (const ParameterError&)
  {
    throw;  // an option that does not suit this frame: main names the option
  }
  catch (const Error& e)
  {
    throw Error (path, e.what ());
  }
  const auto& st = frame_.geometricSegmentation ().getTimings ();
  t.edges_ms = st.edges_ms;
  t.labeling_ms = st.labeling_ms;
  cv::Mat label_image = frame_.geometricSegmentation ().getLabelImage ().clone ();
  std::vector<segmentation::SegmentInstance> segments;
  pcl::StopWatch watch;
  if (s_.mode != "geometry")
  {
    label_image = applyMasks (path, index, *cloud, label_image, segments);
    t.masks_ms = watch.getTime ();
  }
  if (s_.drop_plane)
  {
    watch.reset ();
    plane_removal_.apply (frame_.planes (), label_image);
    t.plane_ms = watch.getTime ();
  }
  watch.reset ();
  write (path, *cloud, label_image, segments);
  t.write_ms = watch.getTime ();

  std::set<std::int32_t> distinct;
  for (int y = 0; y < label_image.rows; ++y)
    for (int x = 0; x < label_image.cols; ++x)
      if (label_image.at<std::int32_t> (y, x) > 0)
        distinct.insert (label_image.at<std::int32_t> (y, x));
  segmentation_ms = t.segmentation ();
  if (s_.verbose)
    std::cout << std::fixed << std::setprecision (2) << fs::path (path).filename ().string () << ": "
              << distinct.size () << " segments; ms: load " << t.load_ms << ", smoothing " << t.smoothing_ms
              << ", normals " << t.normals_ms << ", edges (concave + depth) " << t.edges_ms << ", labelling " << t.labeling_ms << ", segmentation total "
              << t.segmentation () << (s_.drop_plane ? ", plane " + std::to_string (t.plane_ms) : std::string ())
              << ", write " << t.write_ms << "; depth noise " << frame_.noiseScale () << " x Kinect's\n";
  return {{"input", path},
          {"segments", distinct.size ()},
          {"noise_scale", frame_.noiseScale ()},
          {"load_ms", t.load_ms},
          {"smoothing_ms", t.smoothing_ms},
          {"normals_ms", t.normals_ms},
          {"edges_ms", t.edges_ms},
          {"labeling_ms", t.labeling_ms},
          {"segmentation_ms", t.segmentation ()},
          {"masks_ms", t.masks_ms},
          {"plane_ms", t.plane_ms},
          {"write_ms", t.write_ms}};
}
}  // namespace

int
runSegmentFrame (const std::vector<std::string>& args)
{
  // Parse → list the inputs and prepare the output folders → segment each → timings.
  SegmentFrameSettings s;
  if (!parseSegmentFrameSettings (args, s))
    return 0;
  // (in folder mode the output folders would hold files of the inputs' names)
  refuseOutputsOverInputs ({{"--out", s.out}, {"--png", s.png}, {"--edges-png", s.edges_png}, {"--timings", s.timings_path}},
                           {{"INPUT", s.input}, {"--rgb", s.rgb}, {"--masks", s.masks}, {"--intrinsics", s.intrinsics_path},
                            {"--model", s.onnx.model_path}});
  boost::system::error_code ec;
  const bool folder = fs::is_directory (s.input, ec);
  const std::vector<std::string> inputs = listInputs (s.input, {".pcd", ".png"});
  if (inputs.empty ())
    throw Error (s.input, "folder holds no .pcd or .png file");
  std::unique_ptr<FolderOutputs> outputs;
  if (folder)
  {
    for (const std::string& dir : {s.out, s.png, s.edges_png})
      if (!dir.empty () && fs::exists (dir, ec) && !fs::is_directory (dir, ec))
        throw Error (dir, "exists and is not a folder (folder input needs an output folder)");
    outputs = std::make_unique<FolderOutputs> (s, inputs);
  }
  FrameSegmenter segmenter (s, outputs.get ());
  nlohmann::json frames = nlohmann::json::array ();
  std::vector<double> totals;
  for (std::size_t i = 0; i < inputs.size (); ++i)
  {
    double segmentation_ms = 0.0;
    frames.push_back (segmenter.segment (inputs[i], i, segmentation_ms));
    totals.push_back (segmentation_ms);
  }
  if (outputs)
    outputs->commit ();
  if (!s.timings_path.empty ())
    io::writeTextAtomic (s.timings_path,
                         io::jsonText (nlohmann::json ({{"segmentation_ms", pipeline::timingSummary (totals)}, {"frames", frames}}), 1) + "\n");
  if (s.verbose || inputs.size () > 1)
    std::cout << inputs.size () << " frame(s) segmented; geometric segmentation median "
              << pipeline::timingSummary (totals)["median"].get<double> () << " ms per frame\n";
  return 0;
}
}  // namespace cli
}  // namespace cuefusion
