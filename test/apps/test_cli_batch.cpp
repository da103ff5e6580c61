// SPDX-License-Identifier: BSD-3-Clause
// `cuefusion batch`, `batch-task` and `eval --aggregate`, end to end on generated
// sequences: results per sequence, resume, Slurm script, failures, the summary's pooled AP.
#include "test_utils.h"

#include <cuefusion/evaluation/instance_ap.h>

#include <boost/filesystem.hpp>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <map>

using namespace cuefusion;
namespace fs = boost::filesystem;

namespace
{
nlohmann::json
readJson (const std::string& path)
{
  return nlohmann::json::parse (test::readFile (path));
}

/** The report's match lists back as the library's type (the test's own reading of them). */
evaluation::InstanceMatches
matchesOf (const nlohmann::json& report)
{
  const auto list = [] (const nlohmann::json& j) {
    std::vector<evaluation::ThresholdMatches> out;
    for (const nlohmann::json& t : j)
    {
      evaluation::ThresholdMatches m;
      m.threshold = t["threshold"].get<double> ();
      m.truths = t["truths"].get<std::size_t> ();
      m.predictions = t["predictions"].get<std::size_t> ();
      m.missed = t["missed"].get<std::size_t> ();
      m.scores = t["scores"].get<std::vector<double>> ();
      m.true_positive = t["true_positive"].get<std::vector<bool>> ();
      out.push_back (m);
    }
    return out;
  };
  const nlohmann::json& m = report["runs"][0]["instance_ap"]["matches"];
  evaluation::InstanceMatches matches;
  matches.class_agnostic = list (m["class_agnostic"]);
  for (const auto& [name, l] : m["per_class"].items ())
    matches.per_class[name] = list (l);
  return matches;
}

std::size_t
lineCount (const std::string& s)
{
  return static_cast<std::size_t> (std::count (s.begin (), s.end (), '\n'));
}

/** Four short generated sequences (two scenes, two seeds each, Kinect noise), shared by the
  * tests of this file. */
class BatchCli : public ::testing::Test
{
protected:
  static void
  SetUpTestSuite ()
  {
    shared_ = test::sharedFixture ("batch-cli-sequences", [] (const std::string& folder) {
      test::TempDir logs;
      int k = 0;
      for (const std::string scene : {"tabletop", "clutter"})
        for (const int seed : {1, 2})
        {
          const std::string name = "seq" + std::to_string (k++);
          const auto r = test::runCuefusion ("synth --scene " + scene + " --frames 24 --size 160x120 --noise --seed " +
                                               std::to_string (seed) + " --out " + folder + "/" + name,
                                             logs);
          ASSERT_EQ (r.code, 0) << r.err;
        }
    });
  }
  static std::string
  sequence (int k)
  {
    return shared_ + "/seq" + std::to_string (k);
  }
  test::CommandResult
  run (const std::string& args)
  {
    return test::runCuefusion (args, dir);
  }
  static std::string shared_;
  test::TempDir dir;
};
std::string BatchCli::shared_;
}  // namespace

TEST_F (BatchCli, RunsEvaluatesResumesAndWritesSlurmScripts)
{
  const std::string out = dir / "batch";
  const std::string sequences = sequence (0) + " " + sequence (1) + " " + sequence (2) + " " + sequence (3);
  test::CommandResult r = run ("batch " + sequences + " --out " + out + " --jobs 2 --eval --masks detections");
  ASSERT_EQ (r.code, 0) << r.out << r.err;
  EXPECT_NE (r.out.find ("4 of 4 sequence(s) to do"), std::string::npos) << r.out;

  // One result folder per sequence, each a complete run with its evaluation.
  const nlohmann::json summary = readJson (out + "/summary.json");
  ASSERT_EQ (summary["sequences"].size (), 4u);
  std::vector<evaluation::InstanceMatches> scenes;
  std::map<std::string, std::time_t> finished;
  double frames = 0.0;
  for (int k = 0; k < 4; ++k)
  {
    const std::string name = "seq" + std::to_string (k), result = out + "/" + name;
    ASSERT_TRUE (fs::exists (result + "/outputs.json")) << name;
    ASSERT_TRUE (fs::exists (result + "/eval/report.json")) << name;
    finished[name] = fs::last_write_time (result + "/outputs.json");
    const nlohmann::json report = readJson (result + "/eval/report.json");
    scenes.push_back (matchesOf (report));
    const nlohmann::json& row = summary["sequences"][static_cast<std::size_t> (k)];
    EXPECT_EQ (row["name"], name);
    EXPECT_EQ (row["status"], "ok");
    EXPECT_EQ (row["frames"].get<double> (), 24.0);
    EXPECT_GT (row["fps"].get<double> (), 0.0);
    // The row carries the sequence's own report, and the report's lists give its AP again.
    const nlohmann::json& ap = report["runs"][0]["instance_ap"]["class_agnostic"];
    EXPECT_EQ (row["ap50"], ap["ap50"]);
    const evaluation::APScores own = evaluation::apFromMatches (scenes.back ().class_agnostic);
    EXPECT_NEAR (own.ap50, ap["ap50"].get<double> (), 1e-12);
    EXPECT_EQ (row["mean_object_iou"], report["runs"][0]["object_iou"]["mean"]);
    frames += row["frames"].get<double> ();
  }
  // The aggregate: sums, and AP pooled over the four sequences' match lists.
  ASSERT_EQ (summary["aggregate"].size (), 1u);
  const nlohmann::json& all = summary["aggregate"][0];
  EXPECT_EQ (all["succeeded"], 4);
  EXPECT_EQ (all["frames"].get<double> (), frames);
  const evaluation::InstanceAPResult pooled = evaluation::pooledInstanceAP (scenes);
  EXPECT_NEAR (all["instance_ap"]["pooled"]["ap50"].get<double> (), pooled.class_agnostic.ap50, 1e-12);
  EXPECT_NEAR (all["instance_ap"]["pooled"]["ap"].get<double> (), pooled.class_agnostic.ap, 1e-12);
  EXPECT_EQ (all["instance_ap"]["truth_instances"].get<std::size_t> (), pooled.truth_instances);
  EXPECT_GT (pooled.truth_instances, 8u);  // both scenes' objects
  const std::string csv = test::readFile (out + "/summary.csv");
  EXPECT_EQ (lineCount (csv), 6u) << csv;  // header, 4 sequences, the aggregate
  EXPECT_TRUE (fs::exists (out + "/summary_plots/quality.png"));
  EXPECT_EQ (lineCount (test::readFile (out + "/joblog.txt")), 4u);  // a line per job (appended: no header)

  // Deleting one result folder, and a run cut short by Ctrl-C (run then writes what it
  // has, marked stopped_early): the next call redoes those two only.
  fs::remove_all (out + "/seq2");
  nlohmann::json cut = readJson (out + "/seq3/outputs.json");
  cut["stopped_early"] = true;
  test::writeFile (out + "/seq3/outputs.json", cut.dump ());
  r = run ("batch " + sequences + " --out " + out + " --jobs 2 --eval --masks detections");
  ASSERT_EQ (r.code, 0) << r.out << r.err;
  EXPECT_NE (r.out.find ("2 of 4 sequence(s) to do (2 complete)"), std::string::npos) << r.out;
  EXPECT_TRUE (fs::exists (out + "/seq2/eval/report.json"));
  EXPECT_EQ (readJson (out + "/seq3/outputs.json")["stopped_early"], false);
  for (const std::string name : {"seq0", "seq1"})
    EXPECT_EQ (fs::last_write_time (out + "/" + name + "/outputs.json"), finished[name]) << name;
  EXPECT_EQ (lineCount (test::readFile (out + "/joblog.txt")), 6u);  // two more jobs

  // --slurm: an array of the sequences still to do, each task the same command.
  fs::remove (out + "/seq1/eval/report.json");  // its evaluation is missing now
  const std::string script = dir / "cuefusion.sbatch";
  r = run ("batch " + sequences + " --out " + out + " --eval --masks detections --slurm " + script);
  ASSERT_EQ (r.code, 0) << r.err;
  const std::string text = test::readFile (script);
  EXPECT_NE (text.find ("#SBATCH --array=1\n"), std::string::npos) << text;
  EXPECT_NE (text.find ("batch-task '" + fs::canonical (out).string () + "' \"$SLURM_ARRAY_TASK_ID\""), std::string::npos) << text;
  // What Slurm would do for task 1: evaluate the existing run without running it again.
  const std::time_t run_time = fs::last_write_time (out + "/seq1/outputs.json");
  const std::string command = "SLURM_ARRAY_TASK_ID=1 bash " + script + " >" + (dir / "task.txt") + " 2>&1";
  ASSERT_EQ (std::system (command.c_str ()), 0) << test::readFile (dir / "task.txt");
  EXPECT_TRUE (fs::exists (out + "/seq1/eval/report.json"));
  EXPECT_EQ (fs::last_write_time (out + "/seq1/outputs.json"), run_time);

  // eval --aggregate over the batch gives the same aggregate.
  r = run ("eval --aggregate " + out + " --out " + (dir / "again") + " --no-plots");
  ASSERT_EQ (r.code, 0) << r.err;
  const nlohmann::json again = readJson (dir / "again/summary.json");
  EXPECT_EQ (again["aggregate"][0]["instance_ap"]["pooled"], summary["aggregate"][0]["instance_ap"]["pooled"]);
  EXPECT_FALSE (fs::exists (dir / "again/summary_plots"));
}

TEST_F (BatchCli, FailedSequenceStopsNothingAndIsInTheSummary)
{
  // A sequence whose depth image is corrupt, listed between two good ones in a list file.
  const std::string broken = dir / "broken";
  fs::create_directories (broken);
  for (fs::recursive_directory_iterator it (sequence (0)), end; it != end; ++it)
  {
    const fs::path target = fs::path (broken) / fs::relative (it->path (), sequence (0));
    if (fs::is_directory (it->path ()))
      fs::create_directories (target);
    else
      fs::copy_file (it->path (), target);
  }
  const fs::path first_depth = *std::min_element (fs::directory_iterator (fs::path (broken) / "depth"), fs::directory_iterator ());
  std::ofstream (first_depth.string (), std::ios::trunc) << "not a png";
  std::ofstream (dir / "list.txt") << "# sequences\n" << sequence (0) << "\n\n" << broken << "\n" << sequence (2) << "\n";

  // Through parallel's host list (':' is this machine; remote hosts are lines like
  // 2/user@host, which this test cannot reach).
  test::writeFile (dir / "hosts.txt", "# hosts\n:\n");
  const std::string out = dir / "batch";
  const test::CommandResult r = run ("batch @" + (dir / "list.txt") + " --out " + out + " --jobs 2 --hosts " + (dir / "hosts.txt"));
  EXPECT_EQ (r.code, 1) << r.out << r.err;
  EXPECT_EQ (lineCount (r.err), 1u) << r.err;
  EXPECT_NE (r.err.find ("1 of 3"), std::string::npos) << r.err;
  const nlohmann::json summary = readJson (out + "/summary.json");
  ASSERT_EQ (summary["sequences"].size (), 3u);
  EXPECT_EQ (summary["sequences"][0]["status"], "ok");
  EXPECT_EQ (summary["sequences"][2]["status"], "ok");
  const nlohmann::json& failed = summary["sequences"][1];
  EXPECT_EQ (failed["name"], "broken");
  EXPECT_EQ (failed["status"], "failed");
  // The run's own one-line error, naming the file.
  EXPECT_NE (failed["error"].get<std::string> ().find (first_depth.filename ().string ()), std::string::npos) << failed["error"];
  EXPECT_EQ (failed["error"].get<std::string> ().rfind ("cuefusion run: ", 0), 0u) << failed["error"];
  EXPECT_EQ (summary["aggregate"][0]["failed"], 1);
  EXPECT_NE (test::readFile (out + "/summary.csv").find ("broken,,failed"), std::string::npos);
  EXPECT_EQ (lineCount (test::readFile (out + "/joblog.txt")), 3u);
}

TEST_F (BatchCli, NamesTellSequencesOfTheSameNameApart)
{
  // 7-Scenes style: chess/seq-01 and kitchen/seq-01.
  for (const std::string scene : {"chess", "kitchen"})
  {
    fs::create_directories (dir / scene);
    fs::create_directory_symlink (sequence (0), dir / (scene + "/seq-01"));
  }
  const test::CommandResult r = run ("batch " + (dir / "chess/seq-01") + " " + (dir / "kitchen/seq-01") + " " + sequence (1) +
                                     " --out " + (dir / "batch") + " --slurm " + (dir / "job.sh"));
  // The symlinks point at one folder: listed twice.
  EXPECT_EQ (r.code, 2) << r.err;
  EXPECT_NE (r.err.find ("listed twice"), std::string::npos) << r.err;

  for (const std::string scene : {"chess", "kitchen"})
  {
    fs::remove (dir / (scene + "/seq-01"));
    fs::create_directory (dir / (scene + "/seq-01"));
  }
  const test::CommandResult ok = run ("batch " + (dir / "chess/seq-01") + " " + (dir / "kitchen/seq-01") + " " + sequence (1) +
                                      " --out " + (dir / "batch") + " --slurm " + (dir / "job.sh"));
  ASSERT_EQ (ok.code, 0) << ok.err;
  const nlohmann::json plan = readJson (dir / "batch/batch.json");
  ASSERT_EQ (plan["sequences"].size (), 3u);
  EXPECT_EQ (plan["sequences"][0]["name"], "chess-seq-01");
  EXPECT_EQ (plan["sequences"][1]["name"], "kitchen-seq-01");
  EXPECT_EQ (plan["sequences"][2]["name"], "seq1");
  EXPECT_NE (test::readFile (dir / "job.sh").find ("#SBATCH --array=0-2\n"), std::string::npos);

  // Names that differ only in characters a folder name replaces ("x y", "x?y", "x_y"): the
  // one named as it is keeps its name, the others are numbered, and every task can run.
  for (const std::string name : {"x y", "x?y", "x_y"})
    fs::create_directories (dir / ("p/" + name));
  const test::CommandResult apart = run ("batch '" + (dir / "p/x y") + "' '" + (dir / "p/x?y") + "' " + (dir / "p/x_y") +
                                         " --out " + (dir / "batch2") + " --slurm " + (dir / "job2.sh"));
  ASSERT_EQ (apart.code, 0) << apart.err;
  const nlohmann::json named = readJson (dir / "batch2/batch.json");
  ASSERT_EQ (named["sequences"].size (), 3u);
  std::map<std::string, std::string> folder_of;
  for (const auto& s : named["sequences"])
    folder_of[fs::path (s["path"].get<std::string> ()).filename ().string ()] = s["name"];
  EXPECT_EQ (folder_of["x_y"], "x_y");
  EXPECT_EQ (folder_of["x y"], "x_y-2");
  EXPECT_EQ (folder_of["x?y"], "x_y-3");
}

TEST_F (BatchCli, BadUsageIsOneLine)
{
  const std::string out = " --out " + (dir / "b");
  const std::vector<std::pair<std::string, int>> cases = {
    {"batch" + out, 2},                                       // no sequences
    {"batch " + sequence (0), 2},                             // no --out
    {"batch " + (dir / "missing") + out, 1},                  // no such folder
    {"batch @" + (dir / "missing.txt") + out, 1},             // no such list
    {"batch openni2" + out, 2},                               // live camera
    {"batch " + sequence (0) + out + " --view", 2},           // needs a display
    {"batch " + sequence (0) + out + " --video v.avi", 2},    // one output for all
    {"batch " + sequence (0) + out + " --jobs 0", 2},
    {"batch " + sequence (0) + out + " --voxel 5", 2},         // run's own range check
    {"batch " + sequence (0) + out + " --eval-plots", 2},
    {"batch " + sequence (0) + out + " --hosts " + (dir / "missing") + " --frames 1", 1},
    {"batch-task " + (dir / "nothing") + " 0", 1},
    {"eval --aggregate " + dir.str () + " --out " + (dir / "s"), 1},  // neither report nor batch
    {"eval --aggregate " + (dir / "report"), 2},                                 // --out needed
  };
  fs::create_directories (dir / "report");
  test::writeFile (dir / "report/report.json", R"({"sequence": "seq", "runs": []})");
  // Malformed files batch and the summary read: one line naming the file.
  fs::create_directories (dir / "plan");
  test::writeFile (dir / "plan/batch.json", R"({"format": "cuefusion batch plan 1", "sequences": 3})");
  fs::create_directories (dir / "matches");
  test::writeFile (dir / "matches/report.json",
                   R"({"sequence": "seq", "runs": [{"name": "a", "instance_ap": {"class_agnostic": {}, "matches": {"class_agnostic": [1, 2]}}}]})");
  for (const std::string& args : {"batch-task " + (dir / "plan") + " 0", "eval --aggregate " + (dir / "plan") + " --out " + (dir / "s"),
                                  "eval --aggregate " + (dir / "matches") + " --out " + (dir / "s")})
  {
    const test::CommandResult r = run (args);
    EXPECT_EQ (r.code, 1) << args << "\n" << r.err;
    EXPECT_EQ (lineCount (r.err), 1u) << args << "\n" << r.err;
    EXPECT_NE (r.err.find ("json"), std::string::npos) << args << "\n" << r.err;
  }
  for (const auto& [args, code] : cases)
  {
    const test::CommandResult r = run (args);
    EXPECT_EQ (r.code, code) << args << "\n" << r.err;
    EXPECT_EQ (lineCount (r.err), 1u) << args << "\n" << r.err;
  }
  // A hosts file GNU parallel cannot parse: one line of cuefusion's naming it, parallel's
  // own report (several lines, a bug report request) kept in parallel.log.
  test::writeFile (dir / "bad_hosts.txt", "bogus line with spaces ://\n");
  const test::CommandResult hosts = run ("batch " + sequence (0) + " --out " + (dir / "bh") + " --hosts " + (dir / "bad_hosts.txt"));
  EXPECT_EQ (hosts.code, 1) << hosts.err;
  EXPECT_EQ (lineCount (hosts.err), 1u) << hosts.err;
  EXPECT_NE (hosts.err.find ("bad_hosts.txt: GNU parallel stopped: "), std::string::npos) << hosts.err;
  EXPECT_NE (test::readFile (dir / "bh/parallel.log").find ("parallel:"), std::string::npos);

  // A task index outside the plan names the index.
  ASSERT_EQ (run ("batch " + sequence (0) + out + " --slurm " + (dir / "job.sh")).code, 0);
  const test::CommandResult r = run ("batch-task " + (dir / "b") + " 7");
  EXPECT_EQ (r.code, 2) << r.err;
  EXPECT_NE (r.err.find ("INDEX"), std::string::npos) << r.err;
}
