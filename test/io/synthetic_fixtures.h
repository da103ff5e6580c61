// SPDX-License-Identifier: BSD-3-Clause
#pragma once

#include "test_utils.h"

#include <cuefusion/simulation/synthetic_sequence.h>

namespace cuefusion
{
namespace test
{
/** The bundled tabletop scene rendered small: \a frames frames of width × height. */
inline simulation::SyntheticSequence
smallTabletop (std::size_t frames, int width, int height, bool noise = false, std::uint64_t seed = 1)
{
  simulation::SyntheticSequenceConfig config;
  config.frames = frames;
  config.width = width;
  config.height = height;
  config.noise.enabled = noise;
  config.seed = seed;
  return simulation::SyntheticSequence (simulation::SyntheticScene::load (tabletopScenePath ()), config);
}
}  // namespace test
}  // namespace cuefusion
