// SPDX-License-Identifier: BSD-3-Clause
// cuefusion batch: `cuefusion run` (and `eval`) once per sequence, through GNU parallel on
// this machine or over SSH, or as a Slurm job array; resumable; then a dataset summary.
//
// The unit of work is one sequence, and GNU parallel and Slurm already schedule such units
// well, so batch does not schedule: it writes a plan (DIR/batch.json) and hands parallel
// (or sbatch) one `cuefusion batch-task DIR K` per sequence. A task runs `cuefusion run`
// into DIR/NAME (whose outputs.json, written last, marks it complete) and, with --eval,
// `cuefusion eval` into DIR/NAME/eval, each as a child process with its output in
// DIR/NAME/batch.log, and records how it ended in DIR/NAME/batch-task.json. A sequence
// that fails stops nothing else; calling batch again redoes only incomplete sequences.
#include "cli.h"
#include "process.h"
#include "summary.h"

#include <cuefusion/common/exceptions.h>
#include <cuefusion/io/file_io.h>
#include <cuefusion/pipeline/run_files.h>

#include <boost/filesystem.hpp>
#include <nlohmann/json.hpp>

#include <chrono>
#include <csignal>
#include <ctime>
#include <fstream>
#include <iostream>
#include <algorithm>
#include <map>
#include <set>
#include <sstream>

#include <fcntl.h>
#include <sys/file.h>
#include <unistd.h>

namespace fs = boost::filesystem;

namespace cuefusion
{
namespace cli
{
namespace
{
const char* kPlanFile = "batch.json";
const char* kTaskFile = "batch-task.json";
const char* kLogFile = "batch.log";
/** How long a stopped task may take to finish its frame and write its outputs before
  * GNU parallel kills it (a large map's files take seconds; Slurm's KillWait is 30 s). */
constexpr int kTaskStopGraceMs = 300000;
/** Names in DIR that are batch's own: no sequence folder may take them. */
const std::set<std::string> kReservedNames = {"batch.json",    "summary.json", "summary.csv", "summary_plots",
                                              "joblog.txt",    "parallel.log", "eval"};
/** Where GNU parallel's own messages go (ssh's too): batch's stderr keeps one line. */
const char* kParallelLog = "parallel.log";

/** What DIR/batch.json holds: everything a task needs, with absolute paths. */
struct BatchPlan
{
  std::string folder;                   ///< DIR
  std::string program;                  ///< the cuefusion executable the tasks run
  bool eval = false;
  std::vector<std::string> run_options;   ///< passed to every `cuefusion run`
  std::string masks;                      ///< --masks: relative = inside each sequence folder
  std::vector<std::string> eval_options;  ///< passed to every `cuefusion eval`
  std::vector<std::pair<std::string, std::string>> sequences;  ///< name, folder

  fs::path
  resultDir (std::size_t k) const
  {
    return fs::path (folder) / sequences[k].first;
  }
};

nlohmann::json
planJson (const BatchPlan& p)
{
  nlohmann::json sequences = nlohmann::json::array ();
  for (const auto& [name, path] : p.sequences)
    sequences.push_back ({{"name", name}, {"path", path}});
  return {{"format", "cuefusion batch plan 1"}, {"folder", p.folder}, {"cuefusion", p.program}, {"eval", p.eval},
          {"run_options", p.run_options}, {"masks", p.masks}, {"eval_options", p.eval_options}, {"sequences", sequences}};
}

BatchPlan
readPlan (const std::string& dir)
{
  const std::string path = (fs::path (dir) / kPlanFile).string ();
  const nlohmann::json j = io::readJsonFile (path);
  BatchPlan p;
  try
  {
    if (j.at ("format").get<std::string> () != "cuefusion batch plan 1")
      throw Error (path, "is not a plan of this version of `cuefusion batch`");
    p.folder = fs::absolute (dir).lexically_normal ().string ();  // the folder may have moved since
    p.program = j.at ("cuefusion").get<std::string> ();
    p.eval = j.at ("eval").get<bool> ();
    p.run_options = j.at ("run_options").get<std::vector<std::string>> ();
    p.masks = j.at ("masks").get<std::string> ();
    p.eval_options = j.at ("eval_options").get<std::vector<std::string>> ();
    std::set<std::string> names;
    for (const nlohmann::json& s : j.at ("sequences"))
    {
      const std::string name = s.at ("name").get<std::string> ();
      if (name.empty () || name.find ('/') != std::string::npos || name == "." || name == ".." || !names.insert (name).second)
        throw Error (path, "sequence name '" + name + "' is empty, not a plain folder name, or listed twice");
      p.sequences.emplace_back (name, s.at ("path").get<std::string> ());
    }
  }
  catch (const nlohmann::json::exception& e)
  {
    throw Error (path, std::string ("is not a batch plan: ") + e.what ());
  }
  return p;
}

/** The run is complete when its outputs.json is there and it was not stopped early (by
  * Ctrl-C: a signal makes run write what it has). */
bool
runComplete (const fs::path& result)
{
  try
  {
    const pipeline::RunFilesSummary files = pipeline::readRunFiles (result.string (), pipeline::kManifestFile);
    return files.has_manifest && !files.stopped_early;
  }
  catch (const std::exception&)
  {
    return false;  // unreadable: run it again
  }
}

/** The evaluation of a complete run is complete when its report is there and not older
  * than the run. */
bool
evalComplete (const fs::path& result)
{
  boost::system::error_code ec;
  const fs::path report = result / "eval" / "report.json";
  if (!fs::is_regular_file (report, ec))
    return false;
  const std::time_t run = fs::last_write_time (result / "outputs.json", ec), evaluated = fs::last_write_time (report, ec);
  return !ec && evaluated >= run;
}

bool
sequenceComplete (const BatchPlan& plan, std::size_t k)
{
  return runComplete (plan.resultDir (k)) && (!plan.eval || evalComplete (plan.resultDir (k)));
}

/** SEQUENCE arguments with every @LIST replaced by the LIST file's lines (blank lines and
  * lines starting with '#' skipped). */
std::vector<std::string>
expandSequences (const std::vector<std::string>& args)
{
  std::vector<std::string> out;
  for (const std::string& a : args)
  {
    if (a.empty () || a.front () != '@')
    {
      out.push_back (a);
      continue;
    }
    std::istringstream lines (io::readTextFile (a.substr (1)));
    std::string line;
    while (std::getline (lines, line))
    {
      const auto begin = line.find_first_not_of (" \t\r"), end = line.find_last_not_of (" \t\r");
      if (begin == std::string::npos || line[begin] == '#')
        continue;
      out.push_back (line.substr (begin, end - begin + 1));
    }
  }
  return out;
}

/** A folder name per sequence: its own name, or as many parent names joined with '-' as
  * it takes to tell it from the others (7-Scenes: chess-seq-01, redkitchen-seq-01), with
  * characters other than letters, digits, '.', '_' and '-' replaced by '_'. Names that
  * differ only in replaced characters ("a b", "a_b") are numbered instead: the one named
  * as it is keeps its name, the others take -2, -3, ... in path order. */
std::vector<std::string>
sequenceNames (const std::vector<fs::path>& paths)
{
  const auto rawName = [] (const fs::path& p, std::size_t depth) {
    std::vector<std::string> parts;
    for (const fs::path& part : p)
      if (part != "/")
        parts.push_back (part.string ());
    std::string name;
    for (std::size_t i = parts.size () > depth ? parts.size () - depth : 0; i < parts.size (); ++i)
      name += (name.empty () ? "" : "-") + parts[i];
    return name;
  };
  const auto folderName = [] (std::string name) {
    for (char& c : name)
      if (!(std::isalnum (static_cast<unsigned char> (c)) || c == '.' || c == '_' || c == '-'))
        c = '_';
    if (name.empty () || name.front () == '.' || kReservedNames.count (name))
      name = "seq-" + name;
    return name;
  };
  std::vector<std::size_t> depth (paths.size (), 1);
  std::vector<std::string> raw (paths.size ()), names (paths.size ());
  // Parents are added while two paths have the same name as they are, until they differ.
  for (bool changed = true; changed;)
  {
    changed = false;
    std::map<std::string, std::vector<std::size_t>> users;
    for (std::size_t i = 0; i < paths.size (); ++i)
      users[raw[i] = rawName (paths[i], depth[i])].push_back (i);
    for (const auto& [name, who] : users)
      if (who.size () > 1)
        for (const std::size_t i : who)
          if (depth[i] < static_cast<std::size_t> (std::distance (paths[i].begin (), paths[i].end ())))
          {
            ++depth[i];
            changed = true;
          }
  }
  std::map<std::string, std::vector<std::size_t>> users;
  for (std::size_t i = 0; i < paths.size (); ++i)
    users[names[i] = folderName (raw[i])].push_back (i);
  std::set<std::string> taken (names.begin (), names.end ());
  for (auto& [name, who] : users)
  {
    std::sort (who.begin (), who.end (), [&] (std::size_t a, std::size_t b) {
      const bool a_as_is = raw[a] == name, b_as_is = raw[b] == name;
      return a_as_is != b_as_is ? a_as_is : paths[a] < paths[b];
    });
    for (std::size_t k = 1, suffix = 2; k < who.size (); ++k)
    {
      while (taken.count (name + "-" + std::to_string (suffix)))
        ++suffix;
      names[who[k]] = name + "-" + std::to_string (suffix);
      taken.insert (names[who[k]]);
    }
  }
  return names;
}

/** The line saying why \a stage ("run" or "eval") failed: its own error line in the log
  * ("cuefusion run: ..."), else the log's last line, else how the process ended. */
std::string
failureLine (const fs::path& log, const std::string& stage, const ProcessResult& result)
{
  std::string own, last;
  boost::system::error_code ec;
  if (fs::is_regular_file (log, ec))
  {
    std::istringstream lines (io::readTextFile (log.string ()));
    std::string line;
    while (std::getline (lines, line))
    {
      if (line.find_first_not_of (" \t\r") == std::string::npos)
        continue;
      last = line;
      if (line.rfind ("cuefusion " + stage + ": ", 0) == 0)
        own = line;
    }
  }
  std::string why = !own.empty () ? own : (!last.empty () ? "cuefusion " + stage + ": " + last : "cuefusion " + stage);
  if (!result.ok () && (result.signal || !result.started || own.empty ()))
    why += " (" + result.describe () + ")";
  return why;
}

std::string
hostName ()
{
  char host[256] = {};
  return gethostname (host, sizeof (host) - 1) == 0 ? std::string (host) : std::string ();
}

std::string
isoTimeNow ()
{
  const std::time_t now = std::time (nullptr);
  std::tm utc{};
  gmtime_r (&now, &utc);
  char text[32];
  std::strftime (text, sizeof (text), "%Y-%m-%dT%H:%M:%SZ", &utc);
  return text;
}

/** "0-3,5,7-9" for Slurm's --array. */
std::string
indexRanges (const std::vector<std::size_t>& indices)
{
  std::ostringstream out;
  for (std::size_t i = 0; i < indices.size ();)
  {
    std::size_t j = i;
    while (j + 1 < indices.size () && indices[j + 1] == indices[j] + 1)
      ++j;
    out << (i ? "," : "") << indices[i];
    if (j > i)
      out << "-" << indices[j];
    i = j + 1;
  }
  return out.str ();
}

/** Single-quoted for a POSIX shell. */
std::string
shellQuoted (const std::string& s)
{
  std::string out = "'";
  for (const char c : s)
    out += c == '\'' ? std::string ("'\\''") : std::string (1, c);
  return out + "'";
}

void
writeSlurmScript (const std::string& file, const BatchPlan& plan, const std::vector<std::size_t>& pending)
{
  std::ostringstream s;
  s << "#!/bin/bash\n"
    << "# Written by `cuefusion batch --slurm`: one array task per sequence still to do (" << pending.size () << " of "
    << plan.sequences.size () << ") of the plan " << (fs::path (plan.folder) / kPlanFile).string () << ".\n"
    << "# Submit: sbatch " << file << "\n"
    << "# Then:   cuefusion eval --aggregate " << plan.folder << "   (summary.json, summary.csv)\n"
    << "# The cluster's nodes need this cuefusion, the sequences and the batch folder at the same paths.\n"
    << "# Resources are a starting point (one run: 2 cores, < 1 GiB on 640x480 at 1 cm voxels); adapt them to your cluster.\n"
    << "#SBATCH --job-name=cuefusion-batch\n"
    << "#SBATCH --array=" << indexRanges (pending) << "\n"
    << "#SBATCH --cpus-per-task=2\n"
    << "#SBATCH --mem=4G\n"
    << "#SBATCH --time=04:00:00\n"
    << "#SBATCH --output=" << (fs::path (plan.folder) / "slurm-%A_%a.out").string () << "\n";
  if (!pending.empty () && pending.back () >= 1001)
    s << "# Note: indices reach " << pending.back () << "; Slurm's default MaxArraySize is 1001 (ask your admin, or split the list).\n";
  s << "set -eu\n"
    << "exec " << shellQuoted (plan.program) << " batch-task " << shellQuoted (plan.folder) << " \"$SLURM_ARRAY_TASK_ID\"\n";
  io::writeTextAtomic (file, s.str ());
  boost::system::error_code ec;
  fs::permissions (file, fs::add_perms | fs::owner_exe | fs::group_exe, ec);
}

/** Holds an exclusive lock on DIR for one batch call; a second call on the same folder
  * at the same time would run the same sequences twice. */
class FolderLock
{
public:
  explicit FolderLock (const std::string& dir)
  {
    const std::string path = (fs::path (dir) / ".batch.lock").string ();
    fd_ = ::open (path.c_str (), O_RDWR | O_CREAT | O_CLOEXEC, 0644);
    if (fd_ < 0)
      throw Error (path, "cannot create the batch lock file");
    if (::flock (fd_, LOCK_EX | LOCK_NB) != 0)
    {
      ::close (fd_);
      throw Error (dir, "another `cuefusion batch` is working in this folder");
    }
  }
  ~FolderLock ()
  {
    ::close (fd_);
  }
  FolderLock (const FolderLock&) = delete;
  FolderLock& operator= (const FolderLock&) = delete;

private:
  int fd_ = -1;
};

/** Run options batch cannot pass on: they name one output or need a display. */
const std::set<std::string> kNotInBatch = {"view", "view-screenshot", "render", "video", "load-volume", "print-config"};
/** Run options holding a path, made absolute so tasks on other hosts or folders find it. */
const std::set<std::string> kPathOptions = {"intrinsics", "model", "classes", "config"};
}  // namespace

std::vector<SequenceResult>
resultsOfBatch (const std::string& dir)
{
  const BatchPlan plan = readPlan (dir);
  std::vector<SequenceResult> rows;
  for (std::size_t k = 0; k < plan.sequences.size (); ++k)
  {
    SequenceResult row;
    row.name = plan.sequences[k].first;
    row.sequence = plan.sequences[k].second;
    const fs::path result = plan.resultDir (k);
    const bool run = runComplete (result), evaluated = run && plan.eval && evalComplete (result);
    if (run)
      addRunStatistics (result.string (), row);
    const fs::path report = result / "eval" / "report.json";
    if (evaluated)
    {
      const nlohmann::json j = io::readJsonFile (report.string ());
      if (!j.contains ("runs") || !j["runs"].is_array () || j["runs"].empty ())
        throw Error (report.string (), "has no run");
      addReportScores (j["runs"][0], report.string (), row);
    }
    boost::system::error_code ec;
    const fs::path task = result / kTaskFile;
    nlohmann::json status;
    if (fs::is_regular_file (task, ec))
      status = io::readJsonFile (task.string ());
    const auto text = [&status] (const char* key) {
      return status.is_object () && status.contains (key) && status[key].is_string () ? status[key].get<std::string> () : std::string ();
    };
    if (run && (!plan.eval || evaluated))
      row.status = "ok";
    else if (text ("status") == "failed")
    {
      row.status = "failed";
      row.error = text ("error").empty () ? "failed (" + task.string () + " has no error line)" : text ("error");
    }
    else
    {
      row.status = "not run";
      row.error = run ? "not evaluated yet" : "no complete run in " + result.string ();
    }
    rows.push_back (std::move (row));
  }
  return rows;
}

int
runBatchTask (const std::vector<std::string>& args)
{
  std::string dir;
  long long index = -1;
  bool redo = false;
  po::options_description options ("options");
  options.add_options ()
    ("folder", po::value (&dir)->required (), "the batch folder (its batch.json)")
    ("index", po::value (&index)->required (), "which sequence of the plan: 0, 1, ... (Slurm: $SLURM_ARRAY_TASK_ID)")
    ("redo", po::bool_switch (&redo), "run and evaluate again even when complete");
  po::positional_options_description positional;
  positional.add ("folder", 1).add ("index", 1);
  po::variables_map vm;
  if (!parseCommandLine ("batch-task", "DIR INDEX [--redo]", args, options, positional, vm))
    return 0;
  const BatchPlan plan = readPlan (dir);
  if (index < 0 || static_cast<std::size_t> (index) >= plan.sequences.size ())
    throw ParameterError ("INDEX", "must lie in [0, " + std::to_string (plan.sequences.size ()) + ") for " + dir);
  const std::size_t k = static_cast<std::size_t> (index);
  const auto& [name, sequence] = plan.sequences[k];
  const fs::path result = plan.resultDir (k), log = result / kLogFile;
  boost::system::error_code ec;
  fs::create_directories (result, ec);
  if (!fs::is_directory (result))
    throw Error (result.string (), "cannot create the result folder" + (ec ? ": " + ec.message () : std::string ()));
  io::writeTextAtomic (log.string (), "# cuefusion batch-task " + std::to_string (k) + " (" + name + ") on " + hostName () + " at " +
                                          isoTimeNow () + "\n");

  nlohmann::json status = {{"name", name}, {"sequence", sequence}, {"index", k},         {"host", hostName ()},
                           {"status", "ok"}, {"stage", nullptr},     {"error", nullptr}, {"run_seconds", nullptr},
                           {"eval_seconds", nullptr}};
  int interrupted = 0;  // SIGINT or SIGTERM passed on to a stage: no later stage starts
  const auto stage = [&] (const std::string& what, std::vector<std::string> argv) {
    const auto t0 = std::chrono::steady_clock::now ();
    argv.insert (argv.begin (), {plan.program, what});
    const ProcessResult r = runProcess (argv, {log.string (), true}, {log.string (), true}, std::string (), true);
    if (r.forwarded)
      interrupted = r.forwarded;
    status[what + "_seconds"] = std::chrono::duration<double> (std::chrono::steady_clock::now () - t0).count ();
    if (r.ok ())
      return true;
    status["status"] = "failed";
    status["stage"] = what;
    status["error"] = failureLine (log, what, r);
    return false;
  };
  bool ok = true, ran = false;
  if (redo || !runComplete (result))
  {
    std::vector<std::string> argv = {sequence, "--out", result.string ()};
    argv.insert (argv.end (), plan.run_options.begin (), plan.run_options.end ());
    if (!plan.masks.empty ())
      argv.insert (argv.end (), {"--masks", fs::path (plan.masks).is_absolute () ? plan.masks : (fs::path (sequence) / plan.masks).string ()});
    ok = stage ("run", argv);
    ran = ok;
  }
  if (interrupted)
  {
    ok = false;
    status["status"] = "failed";
    status["error"] = std::string ("stopped by ") + (interrupted == SIGINT ? "SIGINT" : "SIGTERM");
  }
  if (ok && plan.eval && (ran || redo || !evalComplete (result)))
  {
    std::vector<std::string> argv = {"--run", name + "=" + result.string (), "--gt", sequence, "--out", (result / "eval").string ()};
    argv.insert (argv.end (), plan.eval_options.begin (), plan.eval_options.end ());
    ok = stage ("eval", argv);
  }
  status["finished"] = isoTimeNow ();
  io::writeTextAtomic ((result / kTaskFile).string (), io::jsonText (status, 2) + "\n");
  if (ok)
    std::cout << name << ": " << (status["run_seconds"].is_null () && status["eval_seconds"].is_null () ? "complete already" : "done") << "\n";
  else
    std::cout << name << ": failed: " << status["error"].get<std::string> () << "\n";
  return ok ? 0 : 1;
}

namespace
{
/** The sequences named on the command line (@FILE expanded), each once, canonical. */
std::vector<fs::path>
sequencePaths (const std::vector<std::string>& args)
{
  const std::vector<std::string> listed = expandSequences (args);
  if (listed.empty ())
    throw UsageError ("no sequences given");
  std::vector<fs::path> paths;
  std::set<fs::path> seen;
  for (const std::string& s : listed)
  {
    if (s == "openni2" || s.rfind ("openni2:", 0) == 0)
      throw UsageError ("batch processes recorded sequences, not live cameras ('" + s + "')");
    boost::system::error_code ec;
    if (!fs::exists (s, ec))
      throw Error (s, "no such sequence folder or file");
    const fs::path p = fs::canonical (s, ec);
    if (!seen.insert (p).second)
      throw UsageError (s + " is listed twice");
    paths.push_back (p);
  }
  return paths;
}

/** The message of GNU parallel's log \a log that says what went wrong: its first
  * "parallel: Error:" line, else the bug id of its internal errors, else its first line. */
std::string
parallelMessage (const std::string& log)
{
  std::istringstream lines (io::readTextFile (log));
  std::string line, first, bug;
  while (std::getline (lines, line))
  {
    if (line.rfind ("parallel: Error: ", 0) == 0)
      return line.substr (17);
    const std::size_t id = line.find ("The bugid: ");
    if (id != std::string::npos && bug.empty ())
      bug = line.substr (id + 11);
    if (first.empty () && !line.empty ())
      first = line;
  }
  return !bug.empty () ? bug : !first.empty () ? first : std::string ("no message");
}

/** Runs the \a pending tasks of \a plan with GNU parallel (on \a hosts when given). */
void
runTasks (const BatchPlan& plan, const std::vector<std::size_t>& pending, unsigned jobs, const std::string& hosts, bool redo)
{
  if (findOnPath ("parallel").empty ())
    throw Error ("parallel", "GNU parallel is not installed (Debian package parallel; scripts/setup installs it)");
  // --termseq: stopped, parallel sends its tasks TERM and by default TERM again 200 ms
  // later, then KILL: a run still writing its outputs would be cut off and leave a staging
  // folder. One TERM, and KILL only after kTaskStopGraceMs (a second signal to batch
  // still stops everything at once: parallel sends TERM again, and a run's second abandons).
  std::vector<std::string> argv = {"parallel", "--will-cite", "--jobs", std::to_string (jobs), "--halt", "never",
                                   "--termseq", "TERM," + std::to_string (kTaskStopGraceMs) + ",KILL,25",
                                   "--joblog", "+" + (fs::path (plan.folder) / "joblog.txt").string ()};
  if (!hosts.empty ())
  {
    boost::system::error_code ec;
    if (!fs::is_regular_file (hosts, ec))
      throw Error (hosts, "no such hosts file");
    argv.insert (argv.end (), {"--sshloginfile", fs::absolute (hosts).string ()});
  }
  // -q: parallel quotes the words of the command for the shell (paths may hold spaces).
  argv.insert (argv.end (), {"-q", plan.program, "batch-task", plan.folder, "{}"});
  if (redo)
    argv.push_back ("--redo");
  argv.push_back (":::");
  for (const std::size_t k : pending)
    argv.push_back (std::to_string (k));
  // A signal to batch goes on to parallel (which stops starting tasks and passes it on to
  // theirs); batch waits for them all and keeps its folder locked until then.
  const std::string log = (fs::path (plan.folder) / kParallelLog).string ();
  const ProcessResult r = runProcess (argv, Redirect (), {log, false}, std::string (), true);
  if (r.forwarded)
    throw Error (plan.folder, std::string ("stopped by ") + (r.forwarded == SIGINT ? "SIGINT" : "SIGTERM") +
                                " after its running sequences ended; run the same batch again to finish the rest");
  // parallel's exit status counts the failed tasks (the summary tells which); 255 is its
  // own error (a hosts file it cannot parse, ...), which its log's first message names.
  if (!r.started || r.signal)
    throw Error ("parallel", r.describe ());
  if (r.exit_code == 255)
    throw Error (hosts.empty () ? std::string ("parallel") : hosts, "GNU parallel stopped: " + parallelMessage (log) +
                                                                        " (all its messages: " + log + ")");
}
}  // namespace

int
runBatch (const std::vector<std::string>& args)
{
  std::vector<std::string> sequence_args;
  std::string out, hosts, slurm;
  unsigned jobs = 1;
  bool eval = false, redo = false, eval_plots = false, no_plots = false;
  RunSettings settings;
  loadRunConfig (args, settings);  // checked here once, not by every run
  po::options_description own ("batch options");
  own.add_options ()
    ("sequences", po::value (&sequence_args)->multitoken (), "sequence folders; @FILE reads more from FILE, one per line")
    ("out", po::value (&out)->required (), "batch folder: one result folder per sequence, batch.json, joblog.txt, summary.json/.csv")
    ("jobs", po::value (&jobs)->default_value (jobs), "sequences at a time on each host (GNU parallel's --jobs)")
    ("hosts", po::value (&hosts), "GNU parallel --sshloginfile: run on these hosts over SSH (':' = this one); they need "
     "cuefusion, the sequences and --out at the same paths")
    ("eval", po::bool_switch (&eval), "also `cuefusion eval` each run against its sequence (into NAME/eval)")
    ("eval-plots", po::bool_switch (&eval_plots), "with --eval: per-sequence plots too (off: only the summary's plot)")
    ("slurm", po::value (&slurm), "write a Slurm job-array script to FILE (one task per sequence to do) instead of running")
    ("redo", po::bool_switch (&redo), "redo every sequence, complete or not")
    ("no-plots", po::bool_switch (&no_plots), "no summary plot");
  po::options_description run_options ("run options (passed to every run; --masks SUBDIR is each sequence's own SEQUENCE/SUBDIR)");
  addRunOptions (run_options, settings);
  po::options_description options;
  options.add (own).add (run_options);
  po::positional_options_description positional;
  positional.add ("sequences", -1);
  po::variables_map vm;
  std::vector<po::option> parsed;
  if (!parseCommandLine ("batch", "SEQUENCE... --out DIR [--jobs N] [--hosts FILE] [--eval] [--slurm FILE] [run options]", args,
                         options, positional, vm, &parsed))
    return 0;
  checkRunSettings (settings);
  if (jobs < 1 || jobs > 1024)
    throw ParameterError ("--jobs", "must lie in [1, 1024]");
  if (eval_plots && !eval)
    throw UsageError ("--eval-plots needs --eval");
  if (!hosts.empty () && !slurm.empty ())
    throw UsageError ("--hosts and --slurm exclude each other");

  BatchPlan plan;
  plan.folder = fs::absolute (out).lexically_normal ().string ();
  plan.program = selfExecutable ();
  plan.eval = eval;
  if (plan.program.empty ())
    throw Error ("/proc/self/exe", "cannot find the cuefusion executable to run the tasks with");
  for (const po::option& o : parsed)
  {
    if (!run_options.find_nothrow (o.string_key, false))
      continue;
    if (kNotInBatch.count (o.string_key))
      throw UsageError ("--" + o.string_key + " is not available in batch (it names one input or output, or needs a display; run a sequence alone)");
    if (o.string_key == "masks")
    {
      plan.masks = settings.masks;
      continue;
    }
    plan.run_options.push_back ("--" + o.string_key);
    for (const std::string& value : o.value)
      // A path that names no file here (a shipped network by name, --model xyz_instances)
      // is passed as given: the library resolves it through the data directory.
      plan.run_options.push_back (kPathOptions.count (o.string_key) && fs::exists (value) ? fs::absolute (value).string () : value);
  }
  if (eval)
  {
    if (given (vm, "format"))
      plan.eval_options.insert (plan.eval_options.end (), {"--format", settings.format});
    if (given (vm, "intrinsics"))
      plan.eval_options.insert (plan.eval_options.end (), {"--intrinsics", fs::absolute (settings.intrinsics).string ()});
    if (!eval_plots)
      plan.eval_options.push_back ("--no-plots");
  }

  const std::vector<fs::path> paths = sequencePaths (sequence_args);
  const std::vector<std::string> names = sequenceNames (paths);
  for (std::size_t i = 0; i < paths.size (); ++i)
    plan.sequences.emplace_back (names[i], paths[i].string ());

  boost::system::error_code ec;
  fs::create_directories (plan.folder, ec);
  if (!fs::is_directory (plan.folder))
    throw Error (out, "cannot create the batch folder" + (ec ? ": " + ec.message () : std::string ()));
  const FolderLock lock (plan.folder);
  const fs::path plan_file = fs::path (plan.folder) / kPlanFile;
  if (fs::is_regular_file (plan_file, ec))
  {
    const BatchPlan previous = readPlan (plan.folder);
    if (!redo && (previous.run_options != plan.run_options || previous.masks != plan.masks || previous.eval_options != plan.eval_options))
      std::cerr << "cuefusion batch: note: the options differ from the previous batch in " << out
                << "; complete sequences are kept as they are (--redo redoes them)\n";
  }
  io::writeTextAtomic (plan_file.string (), io::jsonText (planJson (plan), 2) + "\n");

  std::vector<std::size_t> pending;
  for (std::size_t k = 0; k < plan.sequences.size (); ++k)
    if (redo || !sequenceComplete (plan, k))
      pending.push_back (k);

  if (!slurm.empty ())
  {
    if (pending.empty ())
    {
      std::cout << "all " << plan.sequences.size () << " sequences are complete: no script written (--redo to redo them)\n";
      return 0;
    }
    writeSlurmScript (slurm, plan, pending);
    std::cout << "wrote " << slurm << ": a job array of " << pending.size () << " task(s) (of " << plan.sequences.size ()
              << " sequences)\n  submit: sbatch " << slurm << "\n  then:   cuefusion eval --aggregate " << plan.folder << "\n";
    return 0;
  }

  std::cout << pending.size () << " of " << plan.sequences.size () << " sequence(s) to do";
  if (pending.size () < plan.sequences.size ())
    std::cout << " (" << plan.sequences.size () - pending.size () << " complete)";
  std::cout << "\n" << std::flush;
  if (!pending.empty ())
    runTasks (plan, pending, jobs, hosts, redo);

  const nlohmann::json summary = writeSummary (plan.folder, resultsOfBatch (plan.folder), no_plots);
  std::size_t failed = 0;
  for (const nlohmann::json& a : summary["aggregate"])
    failed += a["failed"].get<std::size_t> ();
  if (failed)
  {
    const fs::path parallel_log = fs::path (plan.folder) / kParallelLog;
    boost::system::error_code ec;
    const bool parallel_said = fs::is_regular_file (parallel_log, ec) && fs::file_size (parallel_log, ec) > 0 && !ec;
    std::cerr << "cuefusion batch: " << failed << " of " << plan.sequences.size () << " sequence(s) failed or did not finish ("
              << (fs::path (plan.folder) / "summary.csv").string () << " has their errors"
              << (parallel_said ? ", " + parallel_log.string () + " has GNU parallel's and ssh's messages" : std::string ()) << ")\n";
    return 1;
  }
  return 0;
}
}  // namespace cli
}  // namespace cuefusion
