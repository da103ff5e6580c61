// SPDX-License-Identifier: BSD-3-Clause
#include <cuefusion/common/progress.h>

#include <algorithm>
#include <cstdio>
#include <unistd.h>

namespace cuefusion
{
ProgressReporter::ProgressReporter (std::string label, std::size_t total)
  : label_ (std::move (label)), total_ (total), enabled_ (isatty (fileno (stderr)) != 0),
    start_ (std::chrono::steady_clock::now ()), last_draw_ (start_)
{}

ProgressReporter::~ProgressReporter () { finish (); }

void
ProgressReporter::update (std::size_t done)
{
  if (!enabled_)
    return;
  const auto now = std::chrono::steady_clock::now ();
  const bool last = total_ > 0 && done >= total_;
  if (!last && drawn_ && now - last_draw_ < std::chrono::milliseconds (250))
    return;
  last_draw_ = now;
  const double elapsed = std::chrono::duration<double> (now - start_).count ();
  const double fps = elapsed > 0.0 ? done / elapsed : 0.0;
  if (total_ > 0)
  {
    const double left = fps > 0.0 ? (total_ - std::min (done, total_)) / fps : 0.0;
    std::fprintf (stderr, "\r%s %zu/%zu  %.1f fps  %.0f s left   ", label_.c_str (), done, total_, fps, left);
  }
  else
    std::fprintf (stderr, "\r%s %zu  %.1f fps   ", label_.c_str (), done, fps);
  std::fflush (stderr);
  drawn_ = true;
}

void
ProgressReporter::finish ()
{
  if (drawn_)
  {
    std::fprintf (stderr, "\n");
    drawn_ = false;
  }
}
}  // namespace cuefusion
