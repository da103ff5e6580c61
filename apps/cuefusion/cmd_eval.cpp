// SPDX-License-Identifier: BSD-3-Clause
// cuefusion eval: tracking (ATE, RPE), per-frame object IoU and 3D instance AP of one or
// more runs against a sequence's ground truth, as report.json, CSV files and PNG plots.
#include "cli.h"
#include "gnuplot.h"
#include "summary.h"

#include <cuefusion/common/exceptions.h>
#include <cuefusion/common/progress.h>
#include <cuefusion/evaluation/instance_ap.h>
#include <cuefusion/evaluation/object_iou.h>
#include <cuefusion/evaluation/trajectory_error.h>
#include <cuefusion/io/file_io.h>
#include <cuefusion/io/ground_truth.h>
#include <cuefusion/io/map_io.h>
#include <cuefusion/io/mesh_io.h>
#include <cuefusion/io/pose_io.h>
#include <cuefusion/io/sequence.h>
#include <cuefusion/segmentation/segments_file.h>
#include <cuefusion/visualization/mesh_rasterizer.h>

#include <Eigen/Eigenvalues>
#include <boost/filesystem.hpp>
#include <nlohmann/json.hpp>
#include <pcl/conversions.h>
#include <pcl/kdtree/kdtree_flann.h>

#include <cmath>
#include <functional>
#include <iomanip>
#include <iostream>
#include <map>
#include <set>
#include <sstream>
#include <tuple>

namespace fs = boost::filesystem;

namespace cuefusion
{
namespace cli
{
namespace
{
/** What one `cuefusion run` output folder holds, as eval needs it. */
struct RunData
{
  std::string name, dir;
  io::Trajectory trajectory;
  std::map<long long, Eigen::Isometry3d, std::less<long long>,
           Eigen::aligned_allocator<std::pair<const long long, Eigen::Isometry3d>>> pose_at;  ///< µs timestamp → pose
  io::TriangleMesh mesh;
  std::map<std::uint32_t, evaluation::PredictedInstance> segments;  ///< segments.json: id → class, score
  double voxel_size = 0.01;
  // results
  std::vector<std::vector<evaluation::ObjectIoU>> frame_iou;
  std::vector<std::size_t> frame_index;  ///< sequence index of each frame_iou entry
  std::size_t frames_skipped = 0;
};

long long
microseconds (double t)
{
  return std::llround (t * 1e6);
}

/** --run NAME=DIR or DIR (named after the folder). */
std::pair<std::string, std::string>
splitRunSpec (const std::string& spec)
{
  const auto eq = spec.find ('=');
  const std::string dir = eq == std::string::npos ? spec : spec.substr (eq + 1);
  std::string name = eq == std::string::npos ? fs::path (dir).filename ().string () : spec.substr (0, eq);
  if (name.empty () || name == ".")
    name = fs::absolute (dir).parent_path ().filename ().string ();
  return {name, dir};
}

RunData
loadRun (const std::string& spec, bool need_mesh)
{
  RunData run;
  std::tie (run.name, run.dir) = splitRunSpec (spec);
  if (!fs::is_directory (run.dir))
    throw Error (run.dir, "is not a `cuefusion run` output folder");
  const fs::path dir (run.dir);
  run.trajectory = io::readTumTrajectory ((dir / "trajectory.txt").string ());
  for (const io::StampedPose& p : run.trajectory)
    run.pose_at[microseconds (p.timestamp)] = p.pose;
  if (need_mesh)
  {
    run.mesh = io::readMeshPLY ((dir / "mesh.ply").string ());
    if (run.mesh.labels.empty ())
      throw Error ((dir / "mesh.ply").string (), "mesh has no per-vertex label (not written by `cuefusion run`?)");
  }
  else if (!fs::is_directory (dir / "labels") || fs::is_empty (dir / "labels"))
    throw Error ((dir / "labels").string (), "no per-frame labels to score (write them with `cuefusion run --save-every K`)");
  const fs::path segments = dir / "segments.json";
  for (const segmentation::SegmentEntry& entry : segmentation::readSegmentsJson (segments.string ()))
  {
    // Segments with a detector score are ranked by it; the rest (geometry only) tie at 1.
    evaluation::PredictedInstance p;
    p.class_name = entry.class_name;
    if (entry.score >= 0.0)
      p.confidence = entry.score;
    run.segments[entry.id] = p;
  }
  const fs::path tracking = dir / "tracking.json";
  if (fs::exists (tracking))
  {
    try
    {
      run.voxel_size = io::readJsonFile (tracking.string ()).at ("volume").at ("voxel_size").get<double> ();
    }
    catch (const nlohmann::json::exception&)
    {
      // older or hand-made folders: keep the default voxel size
    }
  }
  return run;
}

/** The sequence's reference trajectory from its index (poses in the listing or per-frame files). */
io::Trajectory
referenceTrajectory (const io::DatasetGrabber& dataset)
{
  io::Trajectory reference;
  for (const io::FrameRecord& r : dataset.records ())
  {
    if (r.pose)
      reference.push_back ({r.timestamp, *r.pose});
    else if (!r.pose_path.empty ())
      if (const auto pose = io::readPoseMatrixFile (r.pose_path))
        reference.push_back ({r.timestamp, *pose});
  }
  return reference;
}

/** Ground-truth points take the segment of the nearest map point within \a radius. */
std::vector<std::uint32_t>
transferLabels (const pcl::PointCloud<pcl::PointXYZL>& truth, const pcl::PointCloud<pcl::PointXYZL>::Ptr& map, double radius)
{
  std::vector<std::uint32_t> labels (truth.size (), 0);
  if (map->empty ())
    return labels;
  pcl::KdTreeFLANN<pcl::PointXYZL> tree;
  tree.setInputCloud (map);
  std::vector<int> index (1);
  std::vector<float> distance (1);
  const float r2 = static_cast<float> (radius * radius);
  for (std::size_t i = 0; i < truth.size (); ++i)
    if (tree.nearestKSearch (truth[i], 1, index, distance) == 1 && distance[0] <= r2)
      labels[i] = (*map)[static_cast<std::size_t> (index[0])].label;
  return labels;
}

/** An IoU-over-frames chart, one series per run: point (frame, y) wherever \a value
  * gives y for a run's scored frame. Writes the data files and the PNG; returns its path. */
std::string
iouChart (const std::string& gnuplot, const fs::path& plot_dir, const std::string& stem, const std::string& title,
          const std::string& ylabel, const std::string& style, const std::vector<RunData>& runs,
          const std::function<bool (const RunData&, std::size_t, double&)>& value)
{
  PlotSpec spec;
  spec.output_png = (plot_dir / (stem + ".png")).string ();
  spec.title = title;
  spec.xlabel = "frame";
  spec.ylabel = ylabel;
  spec.yrange = "[0:1.05]";
  for (std::size_t k = 0; k < runs.size (); ++k)
  {
    std::ostringstream data;
    data << "# frame " << ylabel << "\n";
    double y = 0.0;
    for (std::size_t f = 0; f < runs[k].frame_iou.size (); ++f)
      if (value (runs[k], f, y))
        data << runs[k].frame_index[f] << " " << y << "\n";
    const std::string file = (plot_dir / (stem + "_run" + std::to_string (k) + ".dat")).string ();
    io::writeTextAtomic (file, data.str ());
    spec.series.push_back ({file, 1, 2, runs[k].name, style});
  }
  renderPlot (gnuplot, spec);
  return spec.output_png;
}
/** eval --aggregate: one summary over report folders and batch folders. */
int
runAggregate (const std::vector<std::string>& dirs, std::string out, bool no_plots)
{
  std::vector<SequenceResult> rows;
  std::vector<std::string> batches;
  std::set<std::string> seen;  // one folder named twice (or by two paths) would count twice
  for (const std::string& dir : dirs)
  {
    boost::system::error_code ec;
    const fs::path canonical = fs::canonical (dir, ec);
    if (!ec && !seen.insert (canonical.string ()).second)
      throw UsageError ("--aggregate: " + dir + " is named twice");
    std::vector<SequenceResult> found;
    if (fs::is_regular_file (fs::path (dir) / "batch.json", ec))
    {
      found = resultsOfBatch (dir);
      batches.push_back (dir);
    }
    else if (fs::is_regular_file (fs::path (dir) / "report.json", ec))
      found = resultsOfReport (dir);
    else
      throw Error (dir, "holds neither a report.json of `cuefusion eval` nor a batch.json of `cuefusion batch`");
    rows.insert (rows.end (), found.begin (), found.end ());
  }
  if (out.empty ())
  {
    if (batches.size () != 1 || dirs.size () != 1)
      throw UsageError ("--out is required unless --aggregate names one batch folder");
    out = batches.front ();
  }
  writeSummary (out, rows, no_plots);
  return 0;
}
/** eval's options. */
struct EvalSettings
{
  std::vector<std::string> run_specs, aggregate;
  std::string gt, out, format = "auto", intrinsics, labels_from = "final";
  std::size_t every = 1, min_pixels = 100, min_region = 100;
  double match_radius = 0.0;
  bool no_plots = false;

  /** Per-frame IoU from the final map seen from each pose (else the run's labels/). */
  bool finalMap () const { return labels_from == "final"; }
};

/** The sequence's truth: its frames and poses, the labelled cloud when it has one, and
  * the instances that are not objects (floor, walls). */
struct EvalTruth
{
  io::DatasetGrabber::Ptr dataset;
  io::Trajectory reference;
  std::optional<io::GroundTruthCloud> cloud;
  std::set<std::uint32_t> stuff;

  std::string
  classOf (std::uint32_t instance) const
  {
    if (!cloud)
      return std::string ();
    const auto it = cloud->class_names.find (instance);
    return it == cloud->class_names.end () ? std::string () : it->second;
  }
};

/** What eval has found so far: report.json's entry of each run and the CSV files. */
struct EvalReport
{
  std::vector<nlohmann::json> runs;
  std::ostringstream tracking_csv, iou_csv, iou_frames_csv, ap_csv;
  std::set<std::uint32_t> all_objects;  ///< scored in some frame of some run
  std::size_t frames_with_masks = 0;
};

/** Parses eval's command line into \a s; false when --help was given. */
bool
parseEvalSettings (const std::vector<std::string>& args, EvalSettings& s, po::variables_map& vm)
{
  po::options_description options ("options");
  options.add_options ()
    ("run", po::value (&s.run_specs)->composing (), "[NAME=]DIR of a `cuefusion run`; repeat to compare runs (e.g. geometry=out/geo --run fused=out/fused)")
    ("gt", po::value (&s.gt), "the sequence the runs processed (its poses, instance masks and, when present, labelled ground-truth cloud)")
    ("out", po::value (&s.out), "report folder: report.json, CSV files, plots/ (with --aggregate: summary.json, summary.csv, summary_plots/)")
    ("aggregate", po::value (&s.aggregate)->multitoken (), "instead of evaluating: summarize existing results, DIR... being report folders of "
     "`cuefusion eval` or folders of `cuefusion batch` (--out defaults to a single batch folder); AP pooled over the "
     "sequences as the ScanNet benchmark does")
    ("format", po::value (&s.format)->default_value (s.format), "layout of --gt: auto, tum, redwood, 7scenes, scannet")
    ("intrinsics", po::value (&s.intrinsics), "intrinsics file overriding the sequence's own")
    ("labels", po::value (&s.labels_from)->default_value (s.labels_from), "per-frame IoU from the 'final' map seen from each estimated pose, or the run's 'per-frame' labels/ (run --save-every)")
    ("every", po::value (&s.every)->default_value (s.every), "score every K-th frame")
    ("min-pixels", po::value (&s.min_pixels)->default_value (s.min_pixels), "objects with fewer visible pixels in a frame are not scored there")
    ("min-region", po::value (&s.min_region)->default_value (s.min_region), "3D AP: instances with fewer points are skipped (ScanNet: 100)")
    ("match-radius", po::value (&s.match_radius)->default_value (s.match_radius), "3D AP: ground-truth points take the label of the nearest map point within this (metres; 0 = two voxels)")
    ("no-plots", po::bool_switch (&s.no_plots), "write report.json and CSV only");
  po::positional_options_description positional;
  return parseCommandLine ("eval", "--run [NAME=]DIR [--run ...] --gt SEQUENCE --out REPORT_DIR [options]\n"
                           "       cuefusion eval --aggregate DIR... [--out SUMMARY_DIR] [--no-plots]", args, options, positional, vm);
}

void
checkEvalSettings (const EvalSettings& s)
{
  if (s.gt.empty () || s.out.empty ())
    throw UsageError (s.gt.empty () ? "--gt is required" : "--out is required");
  if (s.run_specs.empty ())
    throw UsageError ("at least one --run is needed");
  if (s.labels_from != "final" && s.labels_from != "per-frame")
    throw ParameterError ("--labels", "must be 'final' or 'per-frame', not '" + s.labels_from + "'");
  if (s.every == 0)
    throw ParameterError ("--every", "must be at least 1");
  if (s.min_pixels == 0 || s.min_region == 0)
    throw ParameterError (s.min_pixels == 0 ? "--min-pixels" : "--min-region", "must be at least 1");
  if (!(s.match_radius >= 0.0 && s.match_radius <= 1.0))
    throw ParameterError ("--match-radius", "must lie in [0, 1] metres");
}

/** Every --run, each name once. */
std::vector<RunData>
loadRuns (const EvalSettings& s)
{
  std::set<std::string> names;
  for (const std::string& spec : s.run_specs)
  {
    const std::string name = splitRunSpec (spec).first;
    if (!names.insert (name).second)
      throw UsageError ("two runs are called '" + name + "'; name them with --run NAME=DIR");
  }
  std::vector<RunData> runs;
  for (const std::string& spec : s.run_specs)
    runs.push_back (loadRun (spec, s.finalMap ()));
  return runs;
}

EvalTruth
loadTruth (const EvalSettings& s)
{
  io::SequenceOptions opts;
  opts.format = io::parseSequenceFormat (s.format);
  opts.intrinsics_path = s.intrinsics;
  if (opts.format == io::SequenceFormat::OpenNI2)
    throw ParameterError ("--format", "eval needs a recorded sequence folder");
  EvalTruth truth;
  truth.dataset = io::openDataset (s.gt, opts);
  truth.cloud = io::findGroundTruthCloud (s.gt);
  truth.stuff = truth.cloud ? truth.cloud->ignored : io::syntheticStuffInstances (s.gt);
  truth.reference = referenceTrajectory (*truth.dataset);
  return truth;
}

/** ATE and RPE (one frame, one second) of each run against the reference. */
void
evaluateTracking (const std::vector<RunData>& runs, const io::Trajectory& reference, EvalReport& report)
{
  report.tracking_csv << "run,pairs,ate_rmse_m,ate_mean_m,ate_median_m,ate_max_m,rpe_frame_trans_rmse_m,rpe_frame_rot_rmse_deg,"
                         "rpe_1s_trans_rmse_m,rpe_1s_rot_rmse_deg\n";
  report.runs.resize (runs.size ());
  for (std::size_t k = 0; k < runs.size (); ++k)
  {
    const RunData& run = runs[k];
    nlohmann::json tracking = nullptr;
    const evaluation::PosePairs pairs = evaluation::associatePoses (run.trajectory, reference, 1e-3);
    if (pairs.size () >= 3)
    {
      const evaluation::TrajectoryError ate = evaluation::absoluteTrajectoryError (run.trajectory, reference, 1e-3);
      tracking = {{"pairs", ate.pairs},
                  {"ate", {{"rmse", ate.rmse}, {"mean", ate.mean}, {"median", ate.median}, {"max", ate.max}}}};
      std::string rpe_cells[2][2];
      int column = 0;
      for (const auto& [key, interval] : {std::make_pair (std::string ("rpe_1_frame"), evaluation::RelativePoseInterval{evaluation::RelativePoseInterval::Unit::Frames, 1.0}),
                                          std::make_pair (std::string ("rpe_1_s"), evaluation::RelativePoseInterval{evaluation::RelativePoseInterval::Unit::Seconds, 1.0})})
      {
        try
        {
          const evaluation::RelativePoseError rpe = evaluation::relativePoseError (run.trajectory, reference, interval, 1e-3);
          tracking[key] = {{"pairs", rpe.pairs},
                           {"translation_rmse", rpe.translation_rmse},
                           {"translation_median", rpe.translation_median},
                           {"rotation_rmse_deg", rpe.rotation_rmse_deg},
                           {"rotation_median_deg", rpe.rotation_median_deg}};
          rpe_cells[column][0] = csvNumber (rpe.translation_rmse);
          rpe_cells[column][1] = csvNumber (rpe.rotation_rmse_deg);
        }
        catch (const Error&)
        {
          tracking[key] = nullptr;  // the sequence is shorter than the interval
        }
        ++column;
      }
      report.tracking_csv << csvText (run.name) << "," << ate.pairs << "," << csvNumber (ate.rmse) << "," << csvNumber (ate.mean) << ","
                          << csvNumber (ate.median) << "," << csvNumber (ate.max) << "," << rpe_cells[0][0] << "," << rpe_cells[0][1] << ","
                          << rpe_cells[1][0] << "," << rpe_cells[1][1] << "\n";
    }
    report.runs[k] = {{"name", run.name}, {"dir", run.dir}, {"tracking", tracking}};
  }
}

/** The labels \a run shows in frame \a i (the final map rendered at the run's pose, or
  * its labels/ image); empty when the run has none for that frame. */
cv::Mat
predictedLabels (const EvalSettings& s, const visualization::MeshRasterizer& rasterizer, const RunData& run, const RGBDFrame& frame,
                 std::size_t i, const cv::Size& size)
{
  if (s.finalMap ())
  {
    const auto pose = run.pose_at.find (microseconds (frame.timestamp));
    if (pose == run.pose_at.end ())
      return cv::Mat ();  // not fused (tracking lost) or beyond the run's frames
    return rasterizer.render (run.mesh, frame.camera, pose->second).labels;
  }
  std::ostringstream name;
  name << std::setw (6) << std::setfill ('0') << i << ".png";
  const fs::path path = fs::path (run.dir) / "labels" / name.str ();
  if (!fs::exists (path))
    return cv::Mat ();
  cv::Mat predicted = io::readLabelImage (path.string ());
  if (predicted.size () != size)
    throw Error (path.string (), "label image size differs from the sequence's frames");
  return predicted;
}

/** Per-frame object IoU of every run on every --every-th frame with instance masks. */
void
scoreFrames (const EvalSettings& s, const EvalTruth& truth, std::vector<RunData>& runs, EvalReport& report)
{
  const visualization::MeshRasterizer rasterizer;
  evaluation::FrameIoUConfig iou_config;
  iou_config.min_truth_pixels = s.min_pixels;
  const io::DatasetGrabber& dataset = *truth.dataset;
  ProgressReporter progress ("eval", dataset.size ());
  for (std::size_t i = 0; i < dataset.size (); i += s.every)
  {
    progress.update (i + 1);
    if (dataset.records ()[i].instance_path.empty ())
      continue;
    const RGBDFrame::Ptr frame = dataset.readFrame (i);
    ++report.frames_with_masks;
    cv::Mat objects = frame->instance_mask.clone ();
    for (int r = 0; r < objects.rows; ++r)
      for (int c = 0; c < objects.cols; ++c)
        if (truth.stuff.count (objects.at<std::uint16_t> (r, c)))
          objects.at<std::uint16_t> (r, c) = 0;
    cv::Mat valid (frame->depth.size (), CV_8U);
    for (int r = 0; r < valid.rows; ++r)
      for (int c = 0; c < valid.cols; ++c)
        valid.at<std::uint8_t> (r, c) = isValidDepth (frame->depth.at<float> (r, c)) ? 255 : 0;
    for (RunData& run : runs)
    {
      const cv::Mat predicted = predictedLabels (s, rasterizer, run, *frame, i, objects.size ());
      if (predicted.empty ())
      {
        ++run.frames_skipped;
        continue;
      }
      run.frame_iou.push_back (evaluation::frameObjectIoU (predicted, objects, valid, iou_config));
      run.frame_index.push_back (i);
    }
  }
  progress.finish ();
}

/** Each run's object IoU per object and frame, into the report and the CSV files. */
void
summarizeObjectIoU (const EvalTruth& truth, const std::vector<RunData>& runs, EvalReport& report)
{
  report.iou_csv << "run,instance,class,frames,mean_iou\n";
  report.iou_frames_csv << "run,frame,instance,class,segment,truth_pixels,segment_pixels,iou\n";
  for (std::size_t k = 0; k < runs.size (); ++k)
  {
    const RunData& run = runs[k];
    const evaluation::SequenceIoU summary = evaluation::summarizeObjectIoU (run.frame_iou);
    nlohmann::json objects = nlohmann::json::array ();
    for (const auto& [id, mean] : summary.object_mean)
    {
      report.all_objects.insert (id);
      objects.push_back ({{"instance", id}, {"class", truth.classOf (id)}, {"frames", summary.object_frames.at (id)}, {"mean_iou", mean}});
      report.iou_csv << csvText (run.name) << "," << id << "," << csvText (truth.classOf (id)) << "," << summary.object_frames.at (id) << ","
                     << csvNumber (mean) << "\n";
    }
    for (std::size_t f = 0; f < run.frame_iou.size (); ++f)
      for (const evaluation::ObjectIoU& o : run.frame_iou[f])
        report.iou_frames_csv << csvText (run.name) << "," << run.frame_index[f] << "," << o.instance << ","
                              << csvText (truth.classOf (o.instance)) << "," << o.segment << "," << o.truth_pixels << ","
                              << o.segment_pixels << "," << csvNumber (o.iou) << "\n";
    report.runs[k]["object_iou"] = {{"mean", run.frame_iou.empty () ? nlohmann::json (nullptr) : nlohmann::json (summary.mean)},
                                    {"frames_scored", run.frame_iou.size ()},
                                    {"frames_skipped", run.frames_skipped},
                                    {"objects", objects}};
  }
}

/** 3D instance AP of each run's map.pcd against the labelled ground-truth cloud. */
void
scoreInstanceAP (const EvalSettings& s, const io::GroundTruthCloud& gt_cloud, const std::vector<RunData>& runs, EvalReport& report)
{
  for (std::size_t k = 0; k < runs.size (); ++k)
  {
    const RunData& run = runs[k];
    const std::string map_path = (fs::path (run.dir) / "map.pcd").string ();
    pcl::PointCloud<pcl::PointXYZL>::Ptr map = pcl::make_shared<pcl::PointCloud<pcl::PointXYZL>> ();
    pcl::fromPCLPointCloud2 (io::readPCD (map_path, {"x", "y", "z", "label"}), *map);
    evaluation::InstanceEvaluationInput input;
    input.truth.reserve (gt_cloud.cloud->size ());
    for (const auto& p : *gt_cloud.cloud)
      input.truth.push_back (p.label);
    input.predicted = transferLabels (*gt_cloud.cloud, map, s.match_radius > 0.0 ? s.match_radius : 2.0 * run.voxel_size);
    for (const auto& [id, name] : gt_cloud.class_names)
      input.truth_instances[id] = {name, gt_cloud.ignored.count (id) > 0};
    input.predicted_instances.insert (run.segments.begin (), run.segments.end ());
    evaluation::InstanceAPConfig ap_config;
    ap_config.min_region_size = s.min_region;
    const evaluation::InstanceAPResult ap = evaluation::evaluateInstanceAP (input, ap_config);
    nlohmann::json per_class = nlohmann::json::object ();
    for (const auto& [name, scores] : ap.per_class)
    {
      per_class[name] = apJson (scores);
      report.ap_csv << csvText (run.name) << "," << csvText (name) << "," << csvNumber (scores.ap) << "," << csvNumber (scores.ap50) << ","
                    << csvNumber (scores.ap25) << "\n";
    }
    report.ap_csv << csvText (run.name) << ",(class-agnostic)," << csvNumber (ap.class_agnostic.ap) << ","
                  << csvNumber (ap.class_agnostic.ap50) << "," << csvNumber (ap.class_agnostic.ap25) << "\n";
    report.runs[k]["instance_ap"] = {{"ground_truth", gt_cloud.source},
                                     {"class_agnostic", apJson (ap.class_agnostic)},
                                     {"class_mean", apJson (ap.class_mean)},
                                     {"per_class", per_class},
                                     {"matches", matchesJson (ap.matches)},
                                     {"truth_instances", ap.truth_instances},
                                     {"predicted_instances", ap.predicted_instances},
                                     {"segmentation", {{"truth_instances", ap.counts.truth},
                                                       {"segments", ap.counts.segments},
                                                       {"over_segmented", ap.counts.over_segmented},
                                                       {"extra_segments", ap.counts.extra_segments},
                                                       {"under_segmented", ap.counts.under_segmented}}}};
  }
}

/** The camera trajectories seen from above (the plane of the reference's two main
  * directions), as plot_dir/trajectory.png; returns its path. */
std::string
trajectoryPlot (const std::string& gnuplot, const fs::path& plot_dir, const io::Trajectory& reference, const std::vector<RunData>& runs)
{
  Eigen::Vector3d mean = Eigen::Vector3d::Zero ();
  for (const io::StampedPose& p : reference)
    mean += p.pose.translation ();
  mean /= static_cast<double> (reference.size ());
  Eigen::Matrix3d covariance = Eigen::Matrix3d::Zero ();
  for (const io::StampedPose& p : reference)
    covariance += (p.pose.translation () - mean) * (p.pose.translation () - mean).transpose ();
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> solver (covariance);
  const Eigen::Vector3d a = solver.eigenvectors ().col (2), b = solver.eigenvectors ().col (1);
  const auto writeTrack = [&] (const io::Trajectory& track, const std::string& file) {
    std::ostringstream data;
    data << "# along_main_axis along_second_axis (metres)\n";
    for (const io::StampedPose& p : track)
      data << (p.pose.translation () - mean).dot (a) << " " << (p.pose.translation () - mean).dot (b) << "\n";
    io::writeTextAtomic (file, data.str ());
  };
  PlotSpec spec;
  spec.output_png = (plot_dir / "trajectory.png").string ();
  spec.title = "camera trajectory, top view";
  spec.xlabel = "main axis (m)";
  spec.ylabel = "second axis (m)";
  spec.equal_axes = true;
  const std::string truth_file = (plot_dir / "trajectory_reference.dat").string ();
  writeTrack (reference, truth_file);
  spec.series.push_back ({truth_file, 1, 2, "ground truth", "lines"});
  for (std::size_t k = 0; k < runs.size (); ++k)
  {
    const std::string file = (plot_dir / ("trajectory_run" + std::to_string (k) + ".dat")).string ();
    writeTrack (runs[k].trajectory, file);
    spec.series.push_back ({file, 1, 2, runs[k].name, "lines"});
  }
  renderPlot (gnuplot, spec);
  return spec.output_png;
}

/** IoU per frame of each object (one line per run), the mean over the objects, and the
  * trajectories, into \a plot_dir; returns the PNGs written. */
std::vector<std::string>
writePlots (const std::string& gnuplot, const fs::path& plot_dir, const EvalTruth& truth, const std::vector<RunData>& runs,
            const std::set<std::uint32_t>& objects)
{
  std::vector<std::string> plots;
  for (const std::uint32_t object : objects)
  {
    const std::string cls = truth.classOf (object);
    plots.push_back (iouChart (gnuplot, plot_dir, "iou_object_" + std::to_string (object),
                               "object " + std::to_string (object) + (cls.empty () ? "" : " (" + cls + ")") + ": IoU per frame", "IoU",
                               "linespoints", runs, [object] (const RunData& run, std::size_t f, double& y) {
                                 for (const evaluation::ObjectIoU& o : run.frame_iou[f])
                                   if (o.instance == object)
                                   {
                                     y = o.iou;
                                     return true;
                                   }
                                 return false;
                               }));
  }
  if (!objects.empty ())
    plots.push_back (iouChart (gnuplot, plot_dir, "iou_mean", "mean object IoU per frame", "mean IoU", "lines", runs,
                               [] (const RunData& run, std::size_t f, double& y) {
                                 if (run.frame_iou[f].empty ())
                                   return false;
                                 double sum = 0.0;
                                 for (const evaluation::ObjectIoU& o : run.frame_iou[f])
                                   sum += o.iou;
                                 y = sum / static_cast<double> (run.frame_iou[f].size ());
                                 return true;
                               }));
  if (truth.reference.size () >= 3)
    plots.push_back (trajectoryPlot (gnuplot, plot_dir, truth.reference, runs));
  return plots;
}

/** One block per run on stdout; where the report went. */
void
printEvalSummary (const nlohmann::json& report, const EvalSettings& s, const EvalTruth& truth, std::size_t frames_with_masks,
                  const std::vector<std::string>& plots, const std::string& plot_note)
{
  const fs::path report_dir (s.out);
  std::cout << "evaluated " << report["runs"].size () << " run(s) against " << s.gt << " (" << frames_with_masks
            << " frames with instance masks"
            << (truth.cloud ? ", ground-truth cloud " + truth.cloud->source : std::string (", no labelled ground-truth cloud")) << ")\n";
  std::cout << std::fixed << std::setprecision (3);
  for (const nlohmann::json& r : report["runs"])
  {
    std::cout << "  " << r["name"].get<std::string> () << ":";
    if (!r["tracking"].is_null ())
      std::cout << " ATE " << r["tracking"]["ate"]["rmse"].get<double> () << " m;";
    if (!r["object_iou"]["mean"].is_null ())
      std::cout << " mean object IoU " << r["object_iou"]["mean"].get<double> () << " over " << r["object_iou"]["frames_scored"].get<std::size_t> ()
                << " frames;";
    if (!r["instance_ap"].is_null ())
    {
      const auto& ap = r["instance_ap"]["class_agnostic"];
      const auto show = [] (const nlohmann::json& v) { return v.is_null () ? std::string ("n/a") : csvNumber (v.get<double> ()); };
      std::cout << " AP " << show (ap["ap"]) << ", AP50 " << show (ap["ap50"]) << ", AP25 " << show (ap["ap25"]);
    }
    std::cout << "\n";
  }
  std::cout << "  report: " << (report_dir / "report.json").string () << " (+ CSV files";
  if (!plots.empty ())
    std::cout << ", " << plots.size () << " plots in " << (report_dir / "plots").string ();
  std::cout << ")\n";
  if (!plot_note.empty ())
    std::cerr << "cuefusion eval: plots " << plot_note << "\n";
}
}  // namespace

int
runEval (const std::vector<std::string>& args)
{
  // Parse → load → evaluate (tracking, per-frame IoU, 3D AP) → write → report.
  EvalSettings s;
  po::variables_map vm;
  if (!parseEvalSettings (args, s, vm))
    return 0;
  if (given (vm, "aggregate"))
    return runAggregate (s.aggregate, s.out, s.no_plots);
  checkEvalSettings (s);
  std::vector<RunData> runs = loadRuns (s);
  const EvalTruth truth = loadTruth (s);

  // The report is written to a staging folder and replaces the previous report as a
  // whole (io::OutputSet); report.json, moved in last, marks it complete.
  io::OutputSet outputs (s.out, {"tracking.csv", "object_iou.csv", "object_iou_frames.csv", "instance_ap.csv", "plots", "report.json"},
                         "report.json");
  EvalReport found;
  evaluateTracking (runs, truth.reference, found);
  scoreFrames (s, truth, runs, found);
  summarizeObjectIoU (truth, runs, found);
  found.ap_csv << "run,class,ap,ap50,ap25\n";
  if (truth.cloud)
    scoreInstanceAP (s, *truth.cloud, runs, found);
  nlohmann::json report = {{"sequence", s.gt}, {"labels", s.labels_from}, {"runs", nlohmann::json::array ()}};
  for (nlohmann::json& r : found.runs)
  {
    if (!r.contains ("instance_ap"))
      r["instance_ap"] = nullptr;
    report["runs"].push_back (r);
  }
  report["frames_with_masks"] = found.frames_with_masks;
  report["ground_truth_cloud"] = truth.cloud ? nlohmann::json (truth.cloud->source) : nlohmann::json (nullptr);

  std::vector<std::string> plots;
  std::string plot_note;
  if (!s.no_plots)
  {
    const std::string gnuplot = findGnuplot ();
    if (gnuplot.empty ())
      plot_note = "skipped: gnuplot not found (Debian package gnuplot-nox; scripts/setup installs it)";
    else
      plots = writePlots (gnuplot, outputs.stagingPath ("plots/"), truth, runs, found.all_objects);
  }
  for (std::string& plot : plots)
    plot = outputs.finalPath ("plots/" + fs::path (plot).filename ().string ());
  report["plots"] = plots;
  if (!plot_note.empty ())
    report["plots_note"] = plot_note;

  io::writeTextAtomic (outputs.stagingPath ("tracking.csv"), found.tracking_csv.str ());
  io::writeTextAtomic (outputs.stagingPath ("object_iou.csv"), found.iou_csv.str ());
  io::writeTextAtomic (outputs.stagingPath ("object_iou_frames.csv"), found.iou_frames_csv.str ());
  io::writeTextAtomic (outputs.stagingPath ("instance_ap.csv"), found.ap_csv.str ());
  io::writeTextAtomic (outputs.stagingPath ("report.json"), io::jsonText (report, 2) + "\n");
  outputs.commit ();
  printEvalSummary (report, s, truth, found.frames_with_masks, plots, plot_note);
  return 0;
}
}  // namespace cli
}  // namespace cuefusion
