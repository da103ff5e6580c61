// SPDX-License-Identifier: BSD-3-Clause
// The ray caster alone, for A/B runs of its kernels: integrates a dataset's frames with the
// reference poses (the pipeline's preprocessing, noise-adaptive filter) and after each one
// times TSDFVolume::raycast at that pose with the filtered depth as hint and the previous
// frame's empty holes as skip mask, as DenseReconstruction (and so FusionPipeline) calls
// it; --no-hole-skip searches every hole every frame. Prints the median over frames of the
// first call ("cold": the integration has just streamed the voxels through the cache) and
// of the fastest of the repeats.
// Usage: cuefusion_bench_raycast SEQUENCE [FRAMES] [REPEATS] [--no-hole-skip]
#include <cuefusion/common/exceptions.h>
#include <cuefusion/io/sequence.h>
#include <cuefusion/reconstruction/dense_reconstruction.h>
#include <cuefusion/reconstruction/preprocessing.h>
#include <cuefusion/reconstruction/tsdf_volume.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <iostream>
#include <string>
#include <vector>

using namespace cuefusion;

namespace
{
double
median (std::vector<double> values)
{
  std::sort (values.begin (), values.end ());
  return values[values.size () / 2];
}
}  // namespace

int
main (int argc, char** argv)
{
  std::vector<std::string> args;
  bool hole_skip = true;
  for (int i = 1; i < argc; ++i)
    if (std::string (argv[i]) == "--no-hole-skip")
      hole_skip = false;
    else
      args.emplace_back (argv[i]);
  if (args.empty () || args.size () > 3)
  {
    std::cerr << "usage: cuefusion_bench_raycast SEQUENCE [FRAMES] [REPEATS] [--no-hole-skip]\n";
    return 2;
  }
  try
  {
    const io::DatasetGrabber::Ptr sequence = io::openDataset (args[0]);
    const std::size_t frames = std::min (sequence->size (), args.size () > 1 ? static_cast<std::size_t> (std::max (1, std::atoi (args[1].c_str ()))) : sequence->size ());
    const int repeats = args.size () > 2 ? std::max (2, std::atoi (args[2].c_str ())) : 3;
    if (!sequence->hasPoses ())
      throw Error (args[0], "has no reference poses");
    reconstruction::DepthPreprocessorConfig preprocessing;
    preprocessing.bilateral.noise_range_sigma = 8.0;  // FusionPipeline's shared smoothing
    const reconstruction::DepthPreprocessor preprocessor (preprocessing);
    reconstruction::TSDFVolume volume;
    reconstruction::RaycastResult result;
    reconstruction::RaycastHoleSkip skip;
    skip.refresh_period = static_cast<unsigned> (reconstruction::DenseReconstructionConfig ().hole_refresh_period);
    std::vector<double> cold, warm;
    for (std::size_t i = 0; i < frames; ++i)
    {
      const RGBDFrame::Ptr frame = sequence->readFrame (i);
      if (!frame->pose)
        continue;
      reconstruction::FramePyramid pyramid;
      preprocessor.compute (frame->depth, frame->camera, pyramid);
      volume.integrate (pyramid[0].depth, frame->color, frame->camera, *frame->pose);
      // As DenseReconstruction: the last raycast's empty holes become this one's skip mask
      // (two buffers, swapped), and the refreshed diagonal moves by one pixel a frame.
      if (hole_skip)
        std::swap (skip.empty_holes, result.empty_holes);
      ++skip.phase;
      reconstruction::RaycastOptions hinted;
      hinted.depth_hint = pyramid[0].depth;
      hinted.hole_skip = skip;
      double fastest = 0.0;
      for (int r = 0; r < repeats; ++r)
      {
        const auto start = std::chrono::steady_clock::now ();
        volume.raycast (frame->camera, *frame->pose, result, hinted);
        const double ms = std::chrono::duration<double, std::milli> (std::chrono::steady_clock::now () - start).count ();
        if (r == 0)
          cold.push_back (ms);
        else
          fastest = r == 1 ? ms : std::min (fastest, ms);
      }
      warm.push_back (fastest);
    }
    if (cold.empty ())
      throw Error (args[0], "no frame with a reference pose");
    std::printf ("%zu frames%s: raycast median %.2f ms (first call), %.2f ms (fastest of %d repeats)\n", cold.size (),
                 hole_skip ? "" : ", no hole skip", median (cold), median (warm), repeats - 1);
  }
  catch (const std::exception& e)
  {
    std::cerr << "cuefusion_bench_raycast: " << e.what () << "\n";
    return 1;
  }
  return 0;
}
