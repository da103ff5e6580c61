// SPDX-License-Identifier: BSD-3-Clause
// Soak: a long generated sequence streamed from the renderer straight into the fusion
// pipeline (no files), to show that memory stays flat once the scene is covered and that a
// frame costs as much at the end as at the start. The camera sweeps the scene's orbit
// forth and back (frame i of a 2·ORBIT-frame loop: continuous motion, every view seen
// again and again) with Kinect noise, tracking by ICP, fused with the simulated
// detector's masks (with its default merge/miss errors).
// Prints one JSON object: per block of frames the median ms of the whole loop and the
// resident memory at the block's end, and the start/end comparison.
// Usage: cuefusion_bench_soak SCENE_FILE [FRAMES=5000] [ORBIT=500] [WxH=320x240]
#include <cuefusion/common/exceptions.h>
#include <cuefusion/simulation/synthetic_scene.h>
#include <cuefusion/simulation/synthetic_sequence.h>
#include <cuefusion/pipeline/fusion_pipeline.h>

#include <nlohmann/json.hpp>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <fstream>
#include <iostream>
#include <string>
#include <vector>

#include <unistd.h>

using namespace cuefusion;

namespace
{
double
median (std::vector<double> values)
{
  std::sort (values.begin (), values.end ());
  return values.empty () ? 0.0 : values[values.size () / 2];
}

/** Resident memory of this process now, MiB (/proc/self/statm: pages). */
double
residentMiB ()
{
  std::ifstream statm ("/proc/self/statm");
  long pages_total = 0, pages_resident = 0;
  statm >> pages_total >> pages_resident;
  return static_cast<double> (pages_resident) * static_cast<double> (sysconf (_SC_PAGESIZE)) / (1024.0 * 1024.0);
}
}  // namespace

int
main (int argc, char** argv)
{
  if (argc < 2 || argc > 5)
  {
    std::cerr << "usage: cuefusion_bench_soak SCENE_FILE [FRAMES=5000] [ORBIT=500] [WxH=320x240]\n";
    return 2;
  }
  try
  {
    const std::size_t frames = argc > 2 ? std::stoul (argv[2]) : 5000;
    const std::size_t orbit = argc > 3 ? std::stoul (argv[3]) : 500;
    int width = 320, height = 240;
    if (argc > 4 && std::sscanf (argv[4], "%dx%d", &width, &height) != 2)
      throw Error (argv[4], "expected WxH");
    simulation::SyntheticSequenceConfig config;
    config.frames = orbit;
    config.width = width;
    config.height = height;
    config.noise.enabled = true;
    config.detector.merge_probability = 0.1;
    config.detector.miss_probability = 0.05;
    const simulation::SyntheticSequence sequence (simulation::SyntheticScene::load (argv[1]), config);

    pipeline::FusionPipelineConfig pipeline_config;
    pipeline_config.mode = pipeline::SegmentationMode::Fused;
    pipeline::FusionPipeline fusion (pipeline_config);
    const std::size_t block = std::max<std::size_t> (1, frames / 20);
    nlohmann::json blocks = nlohmann::json::array ();
    std::vector<double> block_ms;
    std::size_t lost = 0;
    for (std::size_t i = 0; i < frames; ++i)
    {
      const std::size_t k = i % (2 * orbit);
      const std::size_t view = k < orbit ? k : 2 * orbit - 1 - k;  // forth, then back
      RGBDFrame::Ptr frame = sequence.frame (view);
      frame->index = i;
      frame->timestamp = static_cast<double> (i) / 30.0;
      const std::vector<Instance> instances = simulation::toInstances (sequence.detections (*frame));
      const auto t0 = std::chrono::steady_clock::now ();
      const pipeline::PipelineFrameReport report = fusion.process (*frame, &instances);
      block_ms.push_back (std::chrono::duration<double, std::milli> (std::chrono::steady_clock::now () - t0).count ());
      lost += report.reconstruction.tracked ? 0 : 1;
      if ((i + 1) % block == 0 || i + 1 == frames)
      {
        blocks.push_back ({{"frames", i + 1},
                           {"median_ms", median (block_ms)},
                           {"resident_mib", residentMiB ()},
                           {"volume_mib", static_cast<double> (fusion.reconstruction ().volume ().memoryUsage ()) / (1024.0 * 1024.0)},
                           {"segments", fusion.segments ().size ()},
                           {"lost", lost}});
        block_ms.clear ();
        std::cerr << "soak: " << i + 1 << "/" << frames << " frames\r" << std::flush;
      }
    }
    std::cerr << "\n";
    // Start: the first block after one full sweep (the scene is covered); end: the last.
    const nlohmann::json& start = blocks.at (std::min<std::size_t> (blocks.size () - 1, (2 * orbit + block - 1) / block));
    const nlohmann::json& end = blocks.back ();
    const nlohmann::json result = {
      {"scene", argv[1]},
      {"frames", frames},
      {"orbit_frames", orbit},
      {"size", std::to_string (width) + "x" + std::to_string (height)},
      {"blocks", blocks},
      {"covered_at", start},
      {"end", end},
      {"memory_growth_mib", end.at ("resident_mib").get<double> () - start.at ("resident_mib").get<double> ()},
      {"time_ratio_end_to_start", end.at ("median_ms").get<double> () / start.at ("median_ms").get<double> ()}};
    std::cout << result.dump (2) << "\n";
  }
  catch (const std::exception& e)
  {
    std::cerr << "cuefusion_bench_soak: " << describeException (e) << "\n";
    return 1;
  }
  return 0;
}
