// SPDX-License-Identifier: BSD-3-Clause
// cuefusion: object-level 3D segmentation of RGB-D sequences — command-line front end.
// Exit codes: 0 success, 1 failure (bad input, I/O), 2 bad usage.
#include "cli.h"
#include "commands.h"
#include "option_fields.h"
#include "plugin.h"

#include <cuefusion/common/data_directory.h>
#include <cuefusion/common/exceptions.h>
#include <cuefusion/io/file_io.h>

#include <pcl/console/print.h>

#include <iostream>
#include <map>

namespace
{
const char* kUsage =
  "usage: cuefusion COMMAND [OPTIONS]\n"
  "\n"
  "commands:\n"
  "  synth   render a synthetic RGB-D sequence with exact ground truth\n"
  "  synth-views\n"
  "          render random scenes with exact instance masks (training data for a segmenter)\n"
  "  info    describe a sequence: format, frames, resolution, intrinsics, poses, masks\n"
  "  run     process a sequence (folder, openni2[:DEVICE] or .oni file) into a map\n"
  "  segment-frame\n"
  "          geometric segmentation of organized clouds or depth images (PCD/PNG, or folders)\n"
  "  eval    score runs against a sequence's truth: ATE/RPE, per-frame object IoU, 3D instance AP\n"
  "  render  draw a run's labelled mesh from N viewpoints to PNG (no display needed)\n"
  "  batch   run (and eval) many sequences through GNU parallel or a Slurm job array, resumable, with a\n"
  "          dataset summary (AP pooled over the sequences)\n"
  "  batch-task\n"
  "          one sequence of a batch (what batch's parallel jobs and Slurm tasks run)\n"
  "\n"
  "'cuefusion COMMAND --help' describes a command's options; 'cuefusion --version' prints the version.\n";
}

int
main (int argc, char** argv)
{
  using namespace cuefusion::cli;
  // The commands of this executable; the others (nullptr) are libcuefusion_commands.so's.
  const std::map<std::string, int (*) (const std::vector<std::string>&)> commands = {
    {"synth", runSynth}, {"synth-views", runSynthViews}, {"info", runInfo}, {"run", nullptr}, {"segment-frame", nullptr},
    {"eval", nullptr},   {"render", nullptr},            {"batch", nullptr},  {"batch-task", nullptr}};
  if (argc < 2)
  {
    std::cerr << kUsage;
    return 2;
  }
  const std::string command = argv[1];
  if (command == "--help" || command == "-h" || command == "help")
  {
    std::cout << kUsage;
    return 0;
  }
  if (command == "--version" || command == "version")
  {
    std::cout << "cuefusion " << cuefusion::version () << "\n";
    return 0;
  }
  const auto it = commands.find (command);
  if (it == commands.end ())
  {
    std::cerr << "cuefusion: unknown command '" << command << "'\n" << kUsage;
    return 2;
  }
  // Errors reach the user as one line from the command (cuefusion::Error); PCL's own
  // console messages would add a second, so they are off.
  pcl::console::setVerbosityLevel (pcl::console::L_ALWAYS);
  try
  {
    int (*run) (const std::vector<std::string>&) = it->second;
    if (!run)
      for (const Command* c = reinterpret_cast<const Command* (*) ()> (pluginSymbol (kCommandsLibrary, kCommandsSymbol)) ();
           c->name; ++c)
        if (command == c->name)
          run = c->run;
    if (!run)
      throw cuefusion::Error (kCommandsLibrary, "has no command '" + command + "'; it is not this cuefusion's");
    return run (std::vector<std::string> (argv + 2, argv + argc));
  }
  catch (const UsageError& e)
  {
    std::cerr << "cuefusion " << command << ": " << e.what () << " (see 'cuefusion " << command << " --help')\n";
    return 2;
  }
  catch (const cuefusion::ParameterError& e)
  {
    // The library names config fields; the user typed options.
    const std::string option = cuefusion::cli::optionOfParameter (e.parameter ());
    std::cerr << "cuefusion " << command << ": "
              << (option.empty () ? std::string (e.what ()) : option + ": " + e.reason ()) << " (see 'cuefusion "
              << command << " --help')\n";
    return 2;
  }
  catch (const cuefusion::Error& e)
  {
    std::cerr << "cuefusion " << command << ": " << cuefusion::io::OutputSet::finalPaths (e.what ()) << "\n";
    return 1;
  }
  catch (const std::exception& e)  // PCL's, the standard library's, out of memory: named by FileContext
  {
    std::cerr << "cuefusion " << command << ": " << cuefusion::io::OutputSet::finalPaths (cuefusion::describeException (e)) << "\n";
    return 1;
  }
}
