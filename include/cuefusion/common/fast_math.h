// SPDX-License-Identifier: BSD-3-Clause
#pragma once

namespace cuefusion
{
/** \brief floor() as an int without a libm call: baseline x86-64 (SSE2) has no rounding
  * instruction, so std::floor is a function call, and per-pixel and per-voxel loops call
  * it several times per sample. Valid for |x| < 2^31.
  */
inline int
fastFloor (float x)
{
  const int i = static_cast<int> (x);
  return i - (x < static_cast<float> (i));
}
}  // namespace cuefusion
