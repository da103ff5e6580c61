// SPDX-License-Identifier: BSD-3-Clause
// Scene files of `cuefusion synth` (data/scenes/*.scene).
#include "fuzz_input.h"

#include <cuefusion/simulation/synthetic_scene.h>

extern "C" int
LLVMFuzzerTestOneInput (const std::uint8_t* data, std::size_t size)
{
  const std::string path = cuefusion::fuzz::writeInput (data, size, "input.scene");
  cuefusion::fuzz::expectErrorOrSuccess ([&] { cuefusion::simulation::SyntheticScene::load (path); });
  return 0;
}
