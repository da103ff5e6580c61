// SPDX-License-Identifier: BSD-3-Clause
#pragma once

#include <cstdint>

namespace cuefusion
{
/** \brief SplitMix64's finaliser (Steele, Lea, Flood 2014): a bijective 64-bit mix whose
  * every output bit depends on every input bit. The generator's random streams
  * (simulation::mixSeed), the volume's fingerprint (TSDFVolume::fingerprint) and the renderer's
  * printed texture (SceneObject::print) mix with it.
  */
inline std::uint64_t
splitMix64 (std::uint64_t z)
{
  z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ull;
  z = (z ^ (z >> 27)) * 0x94d049bb133111ebull;
  return z ^ (z >> 31);
}
}  // namespace cuefusion
