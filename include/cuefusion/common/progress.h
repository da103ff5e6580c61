// SPDX-License-Identifier: BSD-3-Clause
#pragma once

#include <chrono>
#include <cstddef>
#include <string>

namespace cuefusion
{
/** \brief "frame i/N, fps, time left" on a terminal; silent when stderr is not a terminal.
  * Redraws at most every 0.25 s so it costs nothing in a frame loop.
  */
class ProgressReporter
{
public:
  /** \param total number of steps, 0 when unknown (live cameras) */
  ProgressReporter (std::string label, std::size_t total);
  ~ProgressReporter ();

  /** \brief Report that \a done steps are complete. */
  void update (std::size_t done);
  /** \brief Clears the line (when one was drawn). Called by the destructor too. */
  void finish ();

  /** \brief Force output on or off (default: on when stderr is a terminal). */
  void setEnabled (bool enabled) { enabled_ = enabled; }

private:
  std::string label_;
  std::size_t total_;
  bool enabled_;
  bool drawn_ = false;
  std::chrono::steady_clock::time_point start_;
  std::chrono::steady_clock::time_point last_draw_;
};
}  // namespace cuefusion
