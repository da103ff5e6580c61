// SPDX-License-Identifier: BSD-3-Clause
#pragma once

#include "test_utils.h"

#include <cuefusion/io/synthetic_sequence.h>

namespace cuefusion
{
namespace test
{
/** The bundled tabletop scene rendered small: \a frames frames of width × height. */
inline io::SyntheticSequence
smallTabletop (std::size_t frames, int width, int height, bool noise = false, std::uint64_t seed = 1)
{
  io::SyntheticSequenceConfig config;
  config.frames = frames;
  config.width = width;
  config.height = height;
  config.noise.enabled = noise;
  config.seed = seed;
  return io::SyntheticSequence (io::SyntheticScene::load (tabletopScenePath ()), config);
}
}  // namespace test
}  // namespace cuefusion
