// SPDX-License-Identifier: BSD-3-Clause
// cuefusion eval: tracking (ATE, RPE), per-frame object IoU and 3D instance AP of one or
// more runs against a sequence's ground truth, as report.json, CSV files and PNG plots.
#include "cli.h"
#include "option_fields.h"
#include "gnuplot.h"
#include "summary.h"

#include <cuefusion/common/exceptions.h>
#include <cuefusion/common/progress.h>
#include <cuefusion/evaluation/run_evaluation.h>
#include <cuefusion/io/file_io.h>
#include <cuefusion/io/sequence.h>

#include <Eigen/Eigenvalues>
#include <boost/filesystem.hpp>
#include <nlohmann/json.hpp>

#include <functional>
#include <iomanip>
#include <iostream>
#include <map>
#include <set>
#include <sstream>

namespace fs = boost::filesystem;

namespace cuefusion
{
namespace cli
{
namespace
{
/** A run eval has scored: its outputs and what was found. */
struct RunData
{
  const evaluation::RunOutputs& outputs;
  const evaluation::RunEvaluation& found;
};

/** --run NAME=DIR or DIR (named after the folder). */
std::pair<std::string, std::string>
splitRunSpec (const std::string& spec)
{
  const auto eq = spec.find ('=');
  const std::string dir = eq == std::string::npos ? spec : spec.substr (eq + 1);
  return {eq == std::string::npos ? std::string () : spec.substr (0, eq), dir};
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
    for (std::size_t f = 0; f < runs[k].found.frame_iou.size (); ++f)
      if (value (runs[k], f, y))
        data << runs[k].found.frame_index[f] << " " << y << "\n";
    const std::string file = (plot_dir / (stem + "_run" + std::to_string (k) + ".dat")).string ();
    io::writeTextAtomic (file, data.str ());
    spec.series.push_back ({file, 1, 2, runs[k].outputs.name, style});
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
  evaluation::RunEvaluationConfig config;
  bool no_plots = false;
};

/** What eval has found, as report.json's entry of each run and the CSV files. */
struct EvalReport
{
  std::vector<nlohmann::json> runs;
  std::ostringstream tracking_csv, iou_csv, iou_frames_csv, ap_csv;
  std::set<std::uint32_t> all_objects;  ///< scored in some frame of some run
};

/** Parses eval's command line into \a s; false when --help was given. */
bool
parseEvalSettings (const std::vector<std::string>& args, EvalSettings& s, po::variables_map& vm)
{
  evaluation::RunEvaluationConfig& c = s.config;
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
    (boundOption ("RunEvaluationConfig::every"), po::value (&c.every)->default_value (c.every), "score every K-th frame")
    (boundOption ("FrameIoUConfig::min_truth_pixels"), po::value (&c.frame_iou.min_truth_pixels)->default_value (c.frame_iou.min_truth_pixels), "objects with fewer visible pixels in a frame are not scored there")
    (boundOption ("InstanceAPConfig::min_region_size"), po::value (&c.instance_ap.min_region_size)->default_value (c.instance_ap.min_region_size), "3D AP: instances with fewer points are skipped (ScanNet: 100)")
    (boundOption ("RunEvaluationConfig::match_radius"), po::value (&c.match_radius)->default_value (c.match_radius), "3D AP: ground-truth points take the label of the nearest map point within this (metres; 0 = two voxels)")
    ("no-plots", po::bool_switch (&s.no_plots), "write report.json and CSV only");
  po::positional_options_description positional;
  return parseCommandLine ("eval", "--run [NAME=]DIR [--run ...] --gt SEQUENCE --out REPORT_DIR [options]\n"
                           "       cuefusion eval --aggregate DIR... [--out SUMMARY_DIR] [--no-plots]", args, options, positional, vm);
}

/** The options the library does not check; the config's fields are checked by
  * RunEvaluationConfig::validate (its field names translated to options by main.cpp). */
void
checkEvalSettings (EvalSettings& s)
{
  if (s.gt.empty () || s.out.empty ())
    throw UsageError (s.gt.empty () ? "--gt is required" : "--out is required");
  if (s.run_specs.empty ())
    throw UsageError ("at least one --run is needed");
  if (s.labels_from != "final" && s.labels_from != "per-frame")
    throw ParameterError ("--labels", "must be 'final' or 'per-frame', not '" + s.labels_from + "'");
  s.config.labels = s.labels_from == "final" ? evaluation::RunEvaluationConfig::Labels::FinalMap
                                             : evaluation::RunEvaluationConfig::Labels::PerFrame;
  s.config.validate ();
}

/** Every --run, each name once. */
std::vector<evaluation::RunOutputs>
loadRuns (const EvalSettings& s)
{
  std::set<std::string> names;
  for (const std::string& spec : s.run_specs)
  {
    const auto [given, dir] = splitRunSpec (spec);
    const std::string name = given.empty () ? evaluation::defaultRunName (dir) : given;
    if (!names.insert (name).second)
      throw UsageError ("two runs are called '" + name + "'; name them with --run NAME=DIR");
  }
  std::vector<evaluation::RunOutputs> runs;
  for (const std::string& spec : s.run_specs)
  {
    const auto [name, dir] = splitRunSpec (spec);
    runs.push_back (evaluation::readRunOutputs (dir, s.config.labels == evaluation::RunEvaluationConfig::Labels::FinalMap, name));
  }
  return runs;
}

evaluation::SequenceTruth
loadTruth (const EvalSettings& s)
{
  io::SequenceOptions opts;
  opts.format = io::parseSequenceFormat (s.format);
  opts.intrinsics_path = s.intrinsics;
  if (opts.format == io::SequenceFormat::OpenNI2)
    throw ParameterError ("--format", "eval needs a recorded sequence folder");
  return evaluation::readSequenceTruth (s.gt, opts);
}

nlohmann::json
rpeJson (const std::optional<evaluation::RelativePoseError>& rpe)
{
  if (!rpe)
    return nullptr;  // the sequence is shorter than the interval
  return {{"pairs", rpe->pairs},
          {"translation_rmse", rpe->translation_rmse},
          {"translation_median", rpe->translation_median},
          {"rotation_rmse_deg", rpe->rotation_rmse_deg},
          {"rotation_median_deg", rpe->rotation_median_deg}};
}

/** Each run's ATE and RPE (one frame, one second), into the report and tracking.csv. */
void
reportTracking (const std::vector<RunData>& runs, EvalReport& report)
{
  report.tracking_csv << "run,pairs,ate_rmse_m,ate_mean_m,ate_median_m,ate_max_m,rpe_frame_trans_rmse_m,rpe_frame_rot_rmse_deg,"
                         "rpe_1s_trans_rmse_m,rpe_1s_rot_rmse_deg\n";
  report.runs.resize (runs.size ());
  for (std::size_t k = 0; k < runs.size (); ++k)
  {
    const evaluation::RunOutputs& run = runs[k].outputs;
    nlohmann::json tracking = nullptr;
    if (const auto& t = runs[k].found.tracking)
    {
      const evaluation::TrajectoryError& ate = t->ate;
      tracking = {{"pairs", ate.pairs},
                  {"ate", {{"rmse", ate.rmse}, {"mean", ate.mean}, {"median", ate.median}, {"max", ate.max}}},
                  {"rpe_1_frame", rpeJson (t->rpe_frame)},
                  {"rpe_1_s", rpeJson (t->rpe_second)}};
      const auto cells = [] (const std::optional<evaluation::RelativePoseError>& rpe) {
        return rpe ? csvNumber (rpe->translation_rmse) + "," + csvNumber (rpe->rotation_rmse_deg) : std::string (",");
      };
      report.tracking_csv << csvText (run.name) << "," << ate.pairs << "," << csvNumber (ate.rmse) << "," << csvNumber (ate.mean) << ","
                          << csvNumber (ate.median) << "," << csvNumber (ate.max) << "," << cells (t->rpe_frame) << ","
                          << cells (t->rpe_second) << "\n";
    }
    report.runs[k] = {{"name", run.name}, {"dir", run.dir}, {"tracking", tracking}};
  }
}

/** Each run's object IoU per object and frame, into the report and the CSV files. */
void
reportObjectIoU (const evaluation::SequenceTruth& truth, const std::vector<RunData>& runs, EvalReport& report)
{
  report.iou_csv << "run,instance,class,frames,mean_iou\n";
  report.iou_frames_csv << "run,frame,instance,class,segment,truth_pixels,segment_pixels,iou\n";
  for (std::size_t k = 0; k < runs.size (); ++k)
  {
    const std::string& name = runs[k].outputs.name;
    const evaluation::RunEvaluation& run = runs[k].found;
    const evaluation::SequenceIoU& summary = run.object_iou;
    nlohmann::json objects = nlohmann::json::array ();
    for (const auto& [id, mean] : summary.object_mean)
    {
      report.all_objects.insert (id);
      objects.push_back ({{"instance", id}, {"class", truth.classOf (id)}, {"frames", summary.object_frames.at (id)}, {"mean_iou", mean}});
      report.iou_csv << csvText (name) << "," << id << "," << csvText (truth.classOf (id)) << "," << summary.object_frames.at (id) << ","
                     << csvNumber (mean) << "\n";
    }
    for (std::size_t f = 0; f < run.frame_iou.size (); ++f)
      for (const evaluation::ObjectIoU& o : run.frame_iou[f])
        report.iou_frames_csv << csvText (name) << "," << run.frame_index[f] << "," << o.instance << ","
                              << csvText (truth.classOf (o.instance)) << "," << o.segment << "," << o.truth_pixels << ","
                              << o.segment_pixels << "," << csvNumber (o.iou) << "\n";
    report.runs[k]["object_iou"] = {{"mean", run.frame_iou.empty () ? nlohmann::json (nullptr) : nlohmann::json (summary.mean)},
                                    {"frames_scored", run.frame_iou.size ()},
                                    {"frames_skipped", run.frames_skipped},
                                    {"objects", objects}};
  }
}

/** Each run's 3D instance AP, into the report and instance_ap.csv. */
void
reportInstanceAP (const io::GroundTruthCloud& gt_cloud, const std::vector<RunData>& runs, EvalReport& report)
{
  for (std::size_t k = 0; k < runs.size (); ++k)
  {
    const std::string& name = runs[k].outputs.name;
    if (!runs[k].found.instance_ap)
      continue;
    const evaluation::InstanceAPResult& ap = *runs[k].found.instance_ap;
    nlohmann::json per_class = nlohmann::json::object ();
    for (const auto& [cls, scores] : ap.per_class)
    {
      per_class[cls] = apJson (scores);
      report.ap_csv << csvText (name) << "," << csvText (cls) << "," << csvNumber (scores.ap) << "," << csvNumber (scores.ap50) << ","
                    << csvNumber (scores.ap25) << "\n";
    }
    report.ap_csv << csvText (name) << ",(class-agnostic)," << csvNumber (ap.class_agnostic.ap) << ","
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
    writeTrack (runs[k].outputs.trajectory, file);
    spec.series.push_back ({file, 1, 2, runs[k].outputs.name, "lines"});
  }
  renderPlot (gnuplot, spec);
  return spec.output_png;
}

/** IoU per frame of each object (one line per run), the mean over the objects, and the
  * trajectories, into \a plot_dir; returns the PNGs written. */
std::vector<std::string>
writePlots (const std::string& gnuplot, const fs::path& plot_dir, const evaluation::SequenceTruth& truth, const std::vector<RunData>& runs,
            const std::set<std::uint32_t>& objects)
{
  std::vector<std::string> plots;
  for (const std::uint32_t object : objects)
  {
    const std::string cls = truth.classOf (object);
    plots.push_back (iouChart (gnuplot, plot_dir, "iou_object_" + std::to_string (object),
                               "object " + std::to_string (object) + (cls.empty () ? "" : " (" + cls + ")") + ": IoU per frame", "IoU",
                               "linespoints", runs, [object] (const RunData& run, std::size_t f, double& y) {
                                 for (const evaluation::ObjectIoU& o : run.found.frame_iou[f])
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
                                 if (run.found.frame_iou[f].empty ())
                                   return false;
                                 double sum = 0.0;
                                 for (const evaluation::ObjectIoU& o : run.found.frame_iou[f])
                                   sum += o.iou;
                                 y = sum / static_cast<double> (run.found.frame_iou[f].size ());
                                 return true;
                               }));
  if (truth.reference.size () >= 3)
    plots.push_back (trajectoryPlot (gnuplot, plot_dir, truth.reference, runs));
  return plots;
}

/** One block per run on stdout; where the report went. */
void
printEvalSummary (const nlohmann::json& report, const EvalSettings& s, const evaluation::SequenceTruth& truth, std::size_t frames_with_masks,
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
  const std::vector<evaluation::RunOutputs> run_outputs = loadRuns (s);
  const evaluation::SequenceTruth truth = loadTruth (s);

  // The report is written to a staging folder and replaces the previous report as a
  // whole (io::OutputSet); report.json, moved in last, marks it complete.
  io::OutputSet outputs (s.out, {"tracking.csv", "object_iou.csv", "object_iou_frames.csv", "instance_ap.csv", "plots", "report.json"},
                         "report.json");
  ProgressReporter progress ("eval", truth.dataset->size ());
  const std::vector<evaluation::RunEvaluation> evaluations = evaluation::evaluateRuns (
      run_outputs, truth, s.config, [&progress] (std::size_t done, std::size_t) { progress.update (done); });
  progress.finish ();
  std::vector<RunData> runs;
  for (std::size_t k = 0; k < run_outputs.size (); ++k)
    runs.push_back ({run_outputs[k], evaluations[k]});
  EvalReport found;
  reportTracking (runs, found);
  reportObjectIoU (truth, runs, found);
  found.ap_csv << "run,class,ap,ap50,ap25\n";
  if (truth.cloud)
    reportInstanceAP (*truth.cloud, runs, found);
  nlohmann::json report = {{"sequence", s.gt}, {"labels", s.labels_from}, {"runs", nlohmann::json::array ()}};
  for (nlohmann::json& r : found.runs)
  {
    if (!r.contains ("instance_ap"))
      r["instance_ap"] = nullptr;
    report["runs"].push_back (r);
  }
  const std::size_t frames_with_masks = runs.empty () ? 0 : runs.front ().found.frames_with_masks;
  report["frames_with_masks"] = frames_with_masks;
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
  printEvalSummary (report, s, truth, frames_with_masks, plots, plot_note);
  return 0;
}
}  // namespace cli
}  // namespace cuefusion
