#pragma once

#include <cuefusion/pipeline/fusion_pipeline.h>

#include <boost/program_options.hpp>
#include <nlohmann/json.hpp>

#include <stdexcept>
#include <string>
#include <vector>

namespace cuefusion
{
namespace cli
{
/** Bad command-line usage: exit code 2. */
struct UsageError : std::runtime_error
{
  using std::runtime_error::runtime_error;
};

namespace po = boost::program_options;

/** Parses \a args (without the program and subcommand names) into \a vm. Returns false
  * when --help was given (help already printed). Throws UsageError on bad usage. */
bool
parseCommandLine (const std::string& command, const std::string& synopsis, const std::vector<std::string>& args,
                  po::options_description& options, const po::positional_options_description& positional,
                  po::variables_map& vm);

/** True when a value is given for \a key. */
inline bool
given (const po::variables_map& vm, const std::string& key)
{
  return vm.count (key) > 0 && !vm[key].defaulted ();
}

/** Median and 90th percentile of a list of milliseconds, as JSON. */
nlohmann::json
timingSummary (std::vector<double> values);

/** Input paths of a command that takes a file or a folder: the folder's files with one of
  * \a extensions (lower case, with the dot), sorted by name; or the file itself. */
std::vector<std::string>
listInputs (const std::string& path, const std::vector<std::string>& extensions);

/** --mode with its default (fused when --masks or --model is given, else geometry);
  * UsageError for both sources at once or a mode that needs one without any,
  * ParameterError for an unknown mode. */
pipeline::SegmentationMode
chooseSegmentationMode (const std::string& mode, const std::string& masks, const std::string& model);

int runSynth (const std::vector<std::string>& args);
int runSynthViews (const std::vector<std::string>& args);
int runInfo (const std::vector<std::string>& args);
int runRun (const std::vector<std::string>& args);
int runSegmentFrame (const std::vector<std::string>& args);
int runEval (const std::vector<std::string>& args);
int runRender (const std::vector<std::string>& args);
}  // namespace cli
}  // namespace cuefusion
