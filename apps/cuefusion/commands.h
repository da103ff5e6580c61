// SPDX-License-Identifier: BSD-3-Clause
#pragma once

#include <string>
#include <vector>

namespace cuefusion
{
namespace cli
{
/** One subcommand: its name and its function (arguments after the name; the exit code). */
struct Command
{
  const char* name;
  int (*run) (const std::vector<std::string>& args);
};

/** The commands that process data (run, segment-frame, eval, render, batch, batch-task)
  * live in libcuefusion_commands.so, which the executable loads only to run one of them:
  * they need the whole pipeline — PCL's segmentation, features and search, OpenCV's DNN,
  * about 35 MB resident — while `info`, `synth` and `synth-views` need the io module only.
  * The library exports `extern "C" const Command* NAME ()`: its commands, ending with
  * {nullptr, nullptr}. */
constexpr const char* kCommandsLibrary = "libcuefusion_commands.so";
constexpr const char* kCommandsSymbol = "cuefusion_commands";
}  // namespace cli
}  // namespace cuefusion
