// SPDX-License-Identifier: BSD-3-Clause
// libcuefusion_commands.so's entry point (commands.h).
#include "cli.h"
#include "commands.h"

extern "C" __attribute__ ((visibility ("default"))) const cuefusion::cli::Command*
cuefusion_commands ()
{
  using namespace cuefusion::cli;
  static const Command table[] = {{"run", runRun},         {"segment-frame", runSegmentFrame},
                                  {"eval", runEval},       {"render", runRender},
                                  {"batch", runBatch},     {"batch-task", runBatchTask},
                                  {nullptr, nullptr}};
  return table;
}
