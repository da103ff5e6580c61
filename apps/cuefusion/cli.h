// SPDX-License-Identifier: BSD-3-Clause
#pragma once

#include <cuefusion/evaluation/instance_ap.h>
#include <cuefusion/pipeline/fusion_pipeline.h>
#include <cuefusion/recognition/onnx_instance_segmenter.h>

#include <boost/program_options.hpp>
#include <nlohmann/json.hpp>

#include <functional>
#include <stdexcept>
#include <string>
#include <utility>
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
  * when --help was given (help already printed). Throws UsageError on bad usage. With
  * \a parsed, the options as given are also listed there. */
bool
parseCommandLine (const std::string& command, const std::string& synopsis, const std::vector<std::string>& args,
                  po::options_description& options, const po::positional_options_description& positional,
                  po::variables_map& vm, std::vector<po::option>* parsed = nullptr);

/** True when a value is given for \a key. */
inline bool
given (const po::variables_map& vm, const std::string& key)
{
  return vm.count (key) > 0 && !vm[key].defaulted ();
}

/** A switch that sets \a field to \a to when given; absent, the field keeps its value
  * (the library's default or a settings file's). */
template <class T>
po::typed_value<bool>*
setsWhenGiven (T& field, T to)
{
  return po::bool_switch ()->notifier ([&field, to] (bool on) {
    if (on)
      field = to;
  });
}

/** \a v as JSON, null when it is not finite (NaN: undefined). */
nlohmann::json
numberOrNull (double v);

/** \a v for a CSV cell (6 significant digits), empty when it is not finite. */
std::string
csvNumber (double v);

/** \a s as a CSV cell, quoted when it holds a comma, quote or line break. */
std::string
csvText (const std::string& s);

/** AP, AP50 and AP25 as {"ap", "ap50", "ap25"}, null where undefined. */
nlohmann::json
apJson (const evaluation::APScores& s);

/** Input paths of a command that takes a file or a folder: the folder's files with one of
  * \a extensions (lower case, with the dot), sorted by name; or the file itself. */
std::vector<std::string>
listInputs (const std::string& path, const std::vector<std::string>& extensions);

/** --mode with its default (fused when --masks or --model is given, else geometry);
  * UsageError for both sources at once or a mode that needs one without any,
  * ParameterError for an unknown mode. */
pipeline::SegmentationMode
chooseSegmentationMode (const std::string& mode, const std::string& masks, const std::string& model);

/** The options of `cuefusion run` (batch forwards them to each run). */
struct RunSettings
{
  std::string source, out, format = "auto", intrinsics;
  long long frames = 0, save_every = 0;  ///< signed: "-5" must not wrap to 2^64 - 5
  /// The library's settings: defaults, then --config's file, then the options given
  /// (--voxel, --no-features, ...), each written into its field; the mode is chosen
  /// from `mode` by runPipelineConfig.
  pipeline::FusionPipelineConfig pipeline;
  bool save_volume = false;
  std::string masks, mode;
  bool print_config = false;  ///< --print-config: print the effective settings and stop
  std::string render_dir, video_path, screenshot;
  std::string load_volume;  ///< a volume.tsdf to continue (its .keyframes beside it)
  bool view = false, async_masks = false;
  long long masks_every = 1;  ///< --masks-every: the mask source on every N-th frame (recognition::PeriodicSegmenter)
  bool sequential = false;  ///< --sequential: no reading or masking ahead of the loop
  bool export_objects = false;  ///< objects/ID.ply: each object's part of the mesh
  std::string colors;           ///< --colors: "segments" or "surface" for map.pcd and mesh.ply; "" = each its own
  std::vector<std::string> command_line;  ///< as given (outputs.json records it)
  recognition::OnnxInstanceSegmenterConfig onnx;
};

/** --config FILE of \a args, read before the options are declared (its values become
  * their defaults, so options given override the file): "pipeline" into s.pipeline (its
  * "mode" into s.mode), "network" into s.onnx. Error naming the file and the member. */
void
loadRunConfig (const std::vector<std::string>& args, RunSettings& s);

/** The value of --config in \a args ("--config F" or "--config=F"), or "". */
std::string
configArgument (const std::vector<std::string>& args);

/** Reads the settings file --config names in \a args, if any (io::readSettingsFile),
  * handing each of its parts to the reader of that name, in \a parts' order. A part of
  * another name (not one of \a command's), or a ParameterError of a reader, is an Error naming the file. */
void
readConfigParts (const std::string& command, const std::vector<std::string>& args,
                 const std::vector<std::pair<std::string, std::function<void (const nlohmann::json&)>>>& parts);

/** Adds run's options other than its sequence and --out to \a options, stored in \a s. */
void
addRunOptions (po::options_description& options, RunSettings& s);

/** The effective settings of a run as one settings file: {"pipeline", "network"}. */
nlohmann::json
runConfigJson (const RunSettings& s);

/** Checks the ranges and combinations run refuses: ParameterError or UsageError naming
  * the option. */
void
checkRunSettings (const RunSettings& s);

/** The pipeline's configuration for run's settings (the segmentation mode chosen). */
pipeline::FusionPipelineConfig
runPipelineConfig (const RunSettings& s);

/** Throws UsageError when an output path (option, path) is one of the inputs: cuefusion
  * never writes over what it reads. Paths are compared after resolving links and "..";
  * empty paths are skipped. */
void
refuseOutputsOverInputs (const std::vector<std::pair<std::string, std::string>>& outputs,
                         const std::vector<std::pair<std::string, std::string>>& inputs);

int runSynth (const std::vector<std::string>& args);
int runSynthViews (const std::vector<std::string>& args);
int runInfo (const std::vector<std::string>& args);
int runRun (const std::vector<std::string>& args);
int runSegmentFrame (const std::vector<std::string>& args);
int runEval (const std::vector<std::string>& args);
int runRender (const std::vector<std::string>& args);
int runBatch (const std::vector<std::string>& args);
int runBatchTask (const std::vector<std::string>& args);
}  // namespace cli
}  // namespace cuefusion
