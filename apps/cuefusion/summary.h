// SPDX-License-Identifier: BSD-3-Clause
#pragma once

// Dataset-level summaries of many runs: what `cuefusion batch` writes when its sequences
// are done and what `cuefusion eval --aggregate` writes for existing reports.

#include <cuefusion/evaluation/instance_ap.h>

#include <nlohmann/json.hpp>

#include <optional>
#include <string>
#include <vector>

namespace cuefusion
{
namespace cli
{
/** One row of a summary: one run of one sequence. */
struct SequenceResult
{
  std::string name;            ///< the sequence's name
  std::string method;          ///< the run's name in its report; rows aggregate per method
  std::string sequence;        ///< the sequence folder
  std::string status = "ok";   ///< ok, failed or not run
  std::string error;           ///< the failure's one line
  /** frames, tracked, lost, seconds, fps, loop_ms, ate_rmse_m, mean_object_iou, ap, ap50,
    * ap25 (null where unknown) */
  nlohmann::json values = nlohmann::json::object ();
  std::optional<evaluation::InstanceMatches> matches;  ///< from the report, for pooled AP
};

/** report.json's "matches" of one run: the lists evaluateInstanceAP made. */
nlohmann::json
matchesJson (const evaluation::InstanceMatches& matches);

/** Reads matchesJson() back; cuefusion::Error naming \a source when it is malformed. */
evaluation::InstanceMatches
matchesFromJson (const nlohmann::json& json, const std::string& source);

/** Frames, seconds, fps, loop time, tracking (and ATE when run had reference poses) of a
  * `cuefusion run` output folder into \a row's values; what is not there stays null. */
void
addRunStatistics (const std::string& run_dir, SequenceResult& row);

/** Scores of one run in a report.json (object IoU, AP, ATE, matches) into \a row. */
void
addReportScores (const nlohmann::json& run_report, const std::string& source, SequenceResult& row);

/** One row per run of the eval report in \a dir (its report.json). */
std::vector<SequenceResult>
resultsOfReport (const std::string& dir);

/** One row per sequence of the `cuefusion batch` folder \a dir (its batch.json): its
  * status, run statistics and, when it was evaluated, its scores (cmd_batch.cpp). */
std::vector<SequenceResult>
resultsOfBatch (const std::string& dir);

/** The summary of \a rows: per row and, per method, the dataset aggregate (sums, means,
  * and the AP pooled over sequences as the ScanNet benchmark does). */
nlohmann::json
summaryJson (const std::vector<SequenceResult>& rows);

/** Writes summary.json, summary.csv and summary_plots/ (per-sequence quality; skipped
  * without gnuplot or with \a no_plots) into \a dir as one set (summary.json last), and
  * prints the table on stdout. Returns the summary. */
nlohmann::json
writeSummary (const std::string& dir, const std::vector<SequenceResult>& rows, bool no_plots);
}  // namespace cli
}  // namespace cuefusion
