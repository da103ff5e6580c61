// The ray caster alone, for A/B runs of its kernels: integrates a dataset's frames with the
// reference poses (the pipeline's preprocessing, noise-adaptive filter) and after each one
// times TSDFVolume::raycast at that pose with the filtered depth as hint, as FusionPipeline
// calls it. Prints the median over frames of the first call ("cold": the integration has
// just streamed the voxels through the cache) and of the fastest of the repeats.
// Usage: cuefusion_bench_raycast SEQUENCE [FRAMES] [REPEATS]
#include <cuefusion/common/exceptions.h>
#include <cuefusion/io/sequence.h>
#include <cuefusion/reconstruction/preprocessing.h>
#include <cuefusion/reconstruction/tsdf_volume.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <iostream>
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
  if (argc < 2)
  {
    std::cerr << "usage: cuefusion_bench_raycast SEQUENCE [FRAMES] [REPEATS]\n";
    return 2;
  }
  try
  {
    const io::DatasetGrabber::Ptr sequence = io::openDataset (argv[1]);
    const std::size_t frames = std::min (sequence->size (), argc > 2 ? static_cast<std::size_t> (std::max (1, std::atoi (argv[2]))) : sequence->size ());
    const int repeats = argc > 3 ? std::max (2, std::atoi (argv[3])) : 3;
    if (!sequence->hasPoses ())
      throw Error (argv[1], "has no reference poses");
    reconstruction::DepthPreprocessingConfig preprocessing;
    preprocessing.noise_range_sigma = 8.0;  // FusionPipeline's shared smoothing
    const reconstruction::DepthPreprocessor preprocessor (preprocessing);
    reconstruction::TSDFVolume volume;
    reconstruction::RaycastResult result;
    std::vector<double> cold, warm;
    for (std::size_t i = 0; i < frames; ++i)
    {
      const RGBDFrame::Ptr frame = sequence->readFrame (i);
      if (!frame->pose)
        continue;
      reconstruction::FramePyramid pyramid;
      preprocessor.compute (frame->depth, frame->camera, pyramid);
      volume.integrate (pyramid[0].depth, frame->color, frame->camera, *frame->pose);
      double fastest = 0.0;
      for (int r = 0; r < repeats; ++r)
      {
        const auto start = std::chrono::steady_clock::now ();
        volume.raycast (frame->camera, *frame->pose, pyramid[0].depth, result);
        const double ms = std::chrono::duration<double, std::milli> (std::chrono::steady_clock::now () - start).count ();
        if (r == 0)
          cold.push_back (ms);
        else
          fastest = r == 1 ? ms : std::min (fastest, ms);
      }
      warm.push_back (fastest);
    }
    if (cold.empty ())
      throw Error (argv[1], "no frame with a reference pose");
    std::printf ("%zu frames: raycast median %.2f ms (first call), %.2f ms (fastest of %d repeats)\n", cold.size (),
                 median (cold), median (warm), repeats - 1);
  }
  catch (const std::exception& e)
  {
    std::cerr << "cuefusion_bench_raycast: " << e.what () << "\n";
    return 1;
  }
  return 0;
}
