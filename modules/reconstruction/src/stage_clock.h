// SPDX-License-Identifier: BSD-3-Clause
// The per-stage timer of DenseReconstruction's files. Internal to the reconstruction module.
#pragma once

#include <chrono>

namespace cuefusion
{
namespace reconstruction
{
/** \brief Milliseconds since it was made or last asked. */
class StageClock
{
public:
  double
  lap ()
  {
    const auto now = std::chrono::steady_clock::now ();
    const double ms = std::chrono::duration<double, std::milli> (now - last_).count ();
    last_ = now;
    return ms;
  }

private:
  std::chrono::steady_clock::time_point last_ = std::chrono::steady_clock::now ();
};

}  // namespace reconstruction
}  // namespace cuefusion
