// SPDX-License-Identifier: BSD-3-Clause
#include "summary.h"

#include "cli.h"
#include "gnuplot.h"

#include <cuefusion/common/exceptions.h>
#include <cuefusion/io/file_io.h>
#include <cuefusion/pipeline/run_files.h>

#include <boost/filesystem.hpp>

#include <cmath>
#include <iomanip>
#include <iostream>
#include <map>
#include <sstream>

namespace fs = boost::filesystem;

namespace cuefusion
{
namespace cli
{
namespace
{
/** The columns of a row, in CSV order, with their headers. */
const std::vector<std::pair<std::string, std::string>> kColumns = {
  {"frames", "frames"},           {"tracked", "tracked"},     {"lost", "lost"},
  {"seconds", "seconds"},         {"fps", "fps"},             {"loop_ms", "loop_ms_median"},
  {"ate_rmse_m", "ate_rmse_m"},   {"mean_object_iou", "mean_object_iou"},
  {"ap", "ap"},                   {"ap50", "ap50"},           {"ap25", "ap25"}};

/** json[key] as a number, NaN when it is missing, null or not a number. */
double
numberAt (const nlohmann::json& json, const std::string& key)
{
  if (!json.is_object ())
    return std::nan ("");
  const auto it = json.find (key);
  return it != json.end () && it->is_number () ? it->get<double> () : std::nan ("");
}

std::vector<evaluation::ThresholdMatches>
thresholdListFromJson (const nlohmann::json& list, const std::string& source)
{
  const std::vector<double> thresholds = evaluation::matchThresholds ();
  if (!list.is_array () || list.size () != thresholds.size ())
    throw Error (source, "instance_ap.matches: expected a list of " + std::to_string (thresholds.size ()) + " thresholds");
  std::vector<evaluation::ThresholdMatches> out;
  for (std::size_t k = 0; k < list.size (); ++k)
  {
    const nlohmann::json& j = list[k];
    evaluation::ThresholdMatches m;
    m.threshold = thresholds[k];
    const auto count = [&] (const char* key) {
      if (!j.is_object () || !j.contains (key) || !j[key].is_number_unsigned ())
        throw Error (source, std::string ("instance_ap.matches: '") + key + "' must be a count");
      return j[key].get<std::size_t> ();
    };
    if (!j.contains ("threshold") || !j["threshold"].is_number () || std::abs (j["threshold"].get<double> () - m.threshold) > 1e-9)
      throw Error (source, "instance_ap.matches: thresholds must be " + std::to_string (thresholds.size ()) + " as cuefusion eval writes them");
    m.truths = count ("truths");
    m.predictions = count ("predictions");
    m.missed = count ("missed");
    const nlohmann::json& scores = j.contains ("scores") ? j["scores"] : nlohmann::json ();
    const nlohmann::json& tp = j.contains ("true_positive") ? j["true_positive"] : nlohmann::json ();
    if (!scores.is_array () || !tp.is_array () || scores.size () != tp.size ())
      throw Error (source, "instance_ap.matches: 'scores' and 'true_positive' must be lists of one length");
    for (std::size_t i = 0; i < scores.size (); ++i)
    {
      if (!scores[i].is_number () || !std::isfinite (scores[i].get<double> ()) || !tp[i].is_boolean ())
        throw Error (source, "instance_ap.matches: a score is not a finite number or a true_positive not true/false");
      m.scores.push_back (scores[i].get<double> ());
      m.true_positive.push_back (tp[i].get<bool> ());
    }
    out.push_back (std::move (m));
  }
  return out;
}

nlohmann::json
thresholdListJson (const std::vector<evaluation::ThresholdMatches>& list)
{
  nlohmann::json out = nlohmann::json::array ();
  for (const evaluation::ThresholdMatches& m : list)
    out.push_back ({{"threshold", m.threshold},
                    {"truths", m.truths},
                    {"predictions", m.predictions},
                    {"missed", m.missed},
                    {"scores", m.scores},
                    {"true_positive", m.true_positive}});
  return out;
}


/** The aggregate of one method's rows. */
nlohmann::json
aggregateJson (const std::string& method, const std::vector<const SequenceResult*>& rows)
{
  std::size_t succeeded = 0;
  double frames = 0.0, seconds = 0.0;
  std::vector<double> ate, iou, ap, ap50, ap25;
  std::vector<evaluation::InstanceMatches> matches;
  for (const SequenceResult* r : rows)
  {
    succeeded += r->status == "ok" ? 1 : 0;
    const double f = numberAt (r->values, "frames"), s = numberAt (r->values, "seconds");
    if (std::isfinite (f) && std::isfinite (s))
    {
      frames += f;
      seconds += s;
    }
    ate.push_back (numberAt (r->values, "ate_rmse_m"));
    iou.push_back (numberAt (r->values, "mean_object_iou"));
    ap.push_back (numberAt (r->values, "ap"));
    ap50.push_back (numberAt (r->values, "ap50"));
    ap25.push_back (numberAt (r->values, "ap25"));
    if (r->matches)
      matches.push_back (*r->matches);
  }
  nlohmann::json a = {{"method", method},
                      {"sequences", rows.size ()},
                      {"succeeded", succeeded},
                      {"failed", rows.size () - succeeded},
                      {"frames", frames},
                      {"seconds", seconds},
                      {"fps", numberOrNull (seconds > 0.0 ? frames / seconds : std::nan (""))},
                      {"mean_ate_rmse_m", numberOrNull (evaluation::nanMean (ate))},
                      {"mean_object_iou", numberOrNull (evaluation::nanMean (iou))},
                      {"instance_ap", nullptr}};
  if (!matches.empty ())
  {
    const evaluation::InstanceAPResult pooled = evaluation::pooledInstanceAP (matches);
    nlohmann::json per_class = nlohmann::json::object ();
    for (const auto& [name, scores] : pooled.per_class)
      per_class[name] = apJson (scores);
    a["instance_ap"] = {{"sequences", matches.size ()},
                        {"truth_instances", pooled.truth_instances},
                        {"predicted_instances", pooled.predicted_instances},
                        {"pooled", apJson (pooled.class_agnostic)},
                        {"pooled_class_mean", apJson (pooled.class_mean)},
                        {"pooled_per_class", per_class},
                        {"mean_of_sequences", {{"ap", numberOrNull (evaluation::nanMean (ap))},
                                               {"ap50", numberOrNull (evaluation::nanMean (ap50))},
                                               {"ap25", numberOrNull (evaluation::nanMean (ap25))}}}};
  }
  return a;
}

/** summary_plots/quality.png: mean object IoU and AP50 of each sequence, one colour per
  * method. Returns the PNG's path in the staging folder. */
std::string
qualityPlot (const std::string& gnuplot, const fs::path& plot_dir, const std::vector<SequenceResult>& rows,
             const std::vector<std::string>& methods)
{
  std::map<std::string, int> position;  // sequence name → x
  for (const SequenceResult& r : rows)
    position.emplace (r.name, static_cast<int> (position.size ()));
  PlotSpec spec;
  spec.output_png = (plot_dir / "quality.png").string ();
  spec.title = "quality per sequence";
  spec.xlabel = "sequence";
  spec.ylabel = "mean object IoU, AP50";
  spec.yrange = "[0:1.05]";
  for (std::size_t k = 0; k < methods.size (); ++k)
  {
    std::ostringstream data;
    data << "# x mean_object_iou ap50 sequence\n";
    for (const SequenceResult& r : rows)
      if (r.method == methods[k])
      {
        std::string label = r.name;
        for (char& c : label)
          c = c == '"' || c == '\\' || static_cast<unsigned char> (c) < 0x20 || c == 0x7f ? '_' : c;  // one quoted data field
        const auto cell = [&r] (const char* key) {
          const double v = numberAt (r.values, key);
          return std::isfinite (v) ? csvNumber (v) : std::string ("NaN");
        };
        data << position.at (r.name) << " " << cell ("mean_object_iou") << " " << cell ("ap50") << " \"" << label << "\"\n";
      }
    const std::string file = (plot_dir / ("quality_method" + std::to_string (k) + ".dat")).string ();
    io::writeTextAtomic (file, data.str ());
    const std::string suffix = methods.size () > 1 || !methods[k].empty () ? " (" + methods[k] + ")" : std::string ();
    spec.series.push_back ({file, 1, 2, "mean object IoU" + suffix, "points pt 7 ps 1.6", 4});
    spec.series.push_back ({file, 1, 3, "AP50" + suffix, "points pt 5 ps 1.4", 4});
  }
  renderPlot (gnuplot, spec);
  return spec.output_png;
}
}  // namespace

nlohmann::json
matchesJson (const evaluation::InstanceMatches& matches)
{
  nlohmann::json per_class = nlohmann::json::object ();
  for (const auto& [name, list] : matches.per_class)
    per_class[name] = thresholdListJson (list);
  return {{"class_agnostic", thresholdListJson (matches.class_agnostic)}, {"per_class", per_class}};
}

evaluation::InstanceMatches
matchesFromJson (const nlohmann::json& json, const std::string& source)
{
  if (!json.is_object () || !json.contains ("class_agnostic"))
    throw Error (source, "instance_ap.matches has no class_agnostic list");
  evaluation::InstanceMatches m;
  m.class_agnostic = thresholdListFromJson (json["class_agnostic"], source);
  if (json.contains ("per_class"))
  {
    if (!json["per_class"].is_object ())
      throw Error (source, "instance_ap.matches.per_class must map class names to lists");
    for (const auto& [name, list] : json["per_class"].items ())
      m.per_class[name] = thresholdListFromJson (list, source);
  }
  return m;
}

void
addRunStatistics (const std::string& run_dir, SequenceResult& row)
{
  const pipeline::RunFilesSummary files = pipeline::readRunFiles (run_dir);
  nlohmann::json& v = row.values;
  const auto figure = [] (const std::optional<double>& x) { return numberOrNull (x ? *x : std::nan ("")); };
  const double frames = files.frames.value_or (std::nan ("")), seconds = files.seconds.value_or (std::nan (""));
  v["frames"] = figure (files.frames);
  v["seconds"] = figure (files.seconds);
  v["fps"] = numberOrNull (seconds > 0.0 ? frames / seconds : std::nan (""));
  v["tracked"] = figure (files.tracked);
  v["lost"] = files.lost ? nlohmann::json (static_cast<std::size_t> (*files.lost)) : nlohmann::json (nullptr);
  if (files.ate_rmse)
    v["ate_rmse_m"] = figure (files.ate_rmse);
  v["loop_ms"] = figure (files.loop_ms);
}

void
addReportScores (const nlohmann::json& run, const std::string& source, SequenceResult& row)
{
  nlohmann::json& v = row.values;
  if (run.contains ("tracking") && run["tracking"].is_object () && run["tracking"].contains ("ate"))
    v["ate_rmse_m"] = numberOrNull (numberAt (run["tracking"]["ate"], "rmse"));
  if (run.contains ("object_iou"))
    v["mean_object_iou"] = numberOrNull (numberAt (run["object_iou"], "mean"));
  if (run.contains ("instance_ap") && run["instance_ap"].is_object ())
  {
    const nlohmann::json& ap = run["instance_ap"];
    if (ap.contains ("class_agnostic"))
      for (const char* key : {"ap", "ap50", "ap25"})
        v[key] = numberOrNull (numberAt (ap["class_agnostic"], key));
    if (ap.contains ("matches"))
      row.matches = matchesFromJson (ap["matches"], source);
  }
}

std::vector<SequenceResult>
resultsOfReport (const std::string& dir)
{
  const std::string path = (fs::path (dir) / "report.json").string ();
  const nlohmann::json report = io::readJsonFile (path);
  if (!report.is_object () || !report.contains ("runs") || !report["runs"].is_array () || !report.contains ("sequence") ||
      !report["sequence"].is_string ())
    throw Error (path, "is not a report of `cuefusion eval` (no 'sequence' and 'runs')");
  const std::string sequence = report["sequence"].get<std::string> ();
  std::string name = fs::path (sequence).filename ().string ();
  if (name.empty () || name == ".")
    name = fs::path (sequence).parent_path ().filename ().string ();
  std::vector<SequenceResult> rows;
  for (const nlohmann::json& run : report["runs"])
  {
    if (!run.is_object () || !run.contains ("name") || !run["name"].is_string ())
      throw Error (path, "a run has no name");
    SequenceResult row;
    row.name = name;
    row.method = run["name"].get<std::string> ();
    row.sequence = sequence;
    // Run statistics where the run folder is still where the report saw it.
    if (run.contains ("dir") && run["dir"].is_string ())
    {
      fs::path run_dir (run["dir"].get<std::string> ());
      boost::system::error_code ec;
      if (fs::is_directory (run_dir, ec))
        addRunStatistics (run_dir.string (), row);
    }
    addReportScores (run, path, row);
    rows.push_back (std::move (row));
  }
  return rows;
}

nlohmann::json
summaryJson (const std::vector<SequenceResult>& rows)
{
  nlohmann::json sequences = nlohmann::json::array ();
  std::vector<std::string> methods;
  for (const SequenceResult& r : rows)
  {
    nlohmann::json row = {{"name", r.name}, {"method", r.method}, {"sequence", r.sequence}, {"status", r.status},
                          {"error", r.error.empty () ? nlohmann::json (nullptr) : nlohmann::json (r.error)}};
    for (const auto& [key, header] : kColumns)
      row[key] = r.values.contains (key) ? r.values[key] : nlohmann::json (nullptr);
    sequences.push_back (row);
    if (std::find (methods.begin (), methods.end (), r.method) == methods.end ())
      methods.push_back (r.method);
  }
  nlohmann::json aggregate = nlohmann::json::array ();
  for (const std::string& method : methods)
  {
    std::vector<const SequenceResult*> of_method;
    for (const SequenceResult& r : rows)
      if (r.method == method)
        of_method.push_back (&r);
    aggregate.push_back (aggregateJson (method, of_method));
  }
  return {{"sequences", sequences},
          {"aggregate", aggregate},
          {"ap_note", "pooled: each IoU threshold's matches pooled over all sequences before one AP is computed (ScanNet "
                      "benchmark); mean_of_sequences: the plain mean of per-sequence APs, for comparison"}};
}

nlohmann::json
writeSummary (const std::string& dir, const std::vector<SequenceResult>& rows, bool no_plots)
{
  nlohmann::json summary = summaryJson (rows);
  io::OutputSet outputs (dir, {"summary.csv", "summary_plots", "summary.json"}, "summary.json");

  std::ostringstream csv;
  csv << "name,method,status";
  for (const auto& [key, header] : kColumns)
    csv << "," << header;
  csv << ",error\n";
  const auto cell = [] (const nlohmann::json& v) { return v.is_number () ? csvNumber (v.get<double> ()) : std::string (); };
  for (const nlohmann::json& r : summary["sequences"])
  {
    csv << csvText (r["name"].get<std::string> ()) << "," << csvText (r["method"].get<std::string> ()) << "," << r["status"].get<std::string> ();
    for (const auto& [key, header] : kColumns)
      csv << "," << cell (r[key]);
    csv << "," << csvText (r["error"].is_string () ? r["error"].get<std::string> () : std::string ()) << "\n";
  }
  // One line per method for the whole dataset: sums, means, and the pooled AP.
  for (const nlohmann::json& a : summary["aggregate"])
  {
    const nlohmann::json& ap = a["instance_ap"].is_object () ? a["instance_ap"]["pooled"] : nlohmann::json::object ();
    csv << "(all)," << csvText (a["method"].get<std::string> ()) << "," << a["succeeded"].get<std::size_t> () << "/"
        << a["sequences"].get<std::size_t> () << " ok," << cell (a["frames"]) << ",,," << cell (a["seconds"]) << ","
        << cell (a["fps"]) << ",," << cell (a["mean_ate_rmse_m"]) << "," << cell (a["mean_object_iou"]) << ","
        << cell (ap.value ("ap", nlohmann::json ())) << "," << cell (ap.value ("ap50", nlohmann::json ())) << ","
        << cell (ap.value ("ap25", nlohmann::json ())) << ",\n";
  }

  std::vector<std::string> methods;
  for (const nlohmann::json& a : summary["aggregate"])
    methods.push_back (a["method"].get<std::string> ());
  std::string plot;
  if (!no_plots && !rows.empty ())
  {
    const std::string gnuplot = findGnuplot ();
    if (gnuplot.empty ())
      summary["plots_note"] = "skipped: gnuplot not found (Debian package gnuplot-nox; scripts/setup installs it)";
    else
    {
      qualityPlot (gnuplot, outputs.stagingPath ("summary_plots/"), rows, methods);
      plot = outputs.finalPath ("summary_plots/quality.png");
      summary["plots"] = {plot};
    }
  }
  io::writeTextAtomic (outputs.stagingPath ("summary.csv"), csv.str ());
  io::writeTextAtomic (outputs.stagingPath ("summary.json"), io::jsonText (summary, 2) + "\n");
  outputs.commit ();

  // The table on stdout.
  const auto show = [] (const nlohmann::json& v, int precision) {
    if (!v.is_number ())
      return std::string ("-");
    std::ostringstream s;
    s << std::fixed << std::setprecision (precision) << v.get<double> ();
    return s.str ();
  };
  std::cout << std::left << std::setw (28) << "sequence" << std::setw (10) << "status" << std::right << std::setw (7) << "frames"
            << std::setw (8) << "fps" << std::setw (9) << "ATE m" << std::setw (7) << "IoU" << std::setw (7) << "AP50" << "\n";
  for (const nlohmann::json& r : summary["sequences"])
  {
    std::string name = r["name"].get<std::string> ();
    if (!r["method"].get<std::string> ().empty () && methods.size () > 1)
      name += " (" + r["method"].get<std::string> () + ")";
    std::cout << std::left << std::setw (28) << name << std::setw (10) << r["status"].get<std::string> () << std::right << std::setw (7)
              << show (r["frames"], 0) << std::setw (8) << show (r["fps"], 1) << std::setw (9) << show (r["ate_rmse_m"], 4)
              << std::setw (7) << show (r["mean_object_iou"], 3) << std::setw (7) << show (r["ap50"], 3) << "\n";
    if (r["error"].is_string ())
      std::cout << "    " << r["error"].get<std::string> () << "\n";
  }
  for (const nlohmann::json& a : summary["aggregate"])
  {
    std::cout << "all " << a["sequences"].get<std::size_t> () << " sequences"
              << (a["method"].get<std::string> ().empty () ? std::string () : " (" + a["method"].get<std::string> () + ")") << ": "
              << a["succeeded"].get<std::size_t> () << " ok, " << show (a["frames"], 0) << " frames at " << show (a["fps"], 1)
              << " fps; mean ATE " << show (a["mean_ate_rmse_m"], 4) << " m, mean object IoU " << show (a["mean_object_iou"], 3);
    if (a["instance_ap"].is_object ())
    {
      const nlohmann::json& p = a["instance_ap"]["pooled"];
      std::cout << "; pooled AP " << show (p["ap"], 3) << ", AP50 " << show (p["ap50"], 3) << ", AP25 " << show (p["ap25"], 3);
    }
    std::cout << "\n";
  }
  std::cout << "  summary: " << (fs::path (dir) / "summary.json").string () << " (+ summary.csv"
            << (plot.empty () ? std::string () : ", " + plot) << ")\n";
  return summary;
}
}  // namespace cli
}  // namespace cuefusion
