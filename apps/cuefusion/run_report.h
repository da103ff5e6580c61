// SPDX-License-Identifier: BSD-3-Clause
// What a `cuefusion run` measured frame by frame, and timings.json made of it.
#pragma once

#include <cuefusion/io/pose_io.h>
#include <cuefusion/pipeline/fusion_pipeline.h>
#include <cuefusion/recognition/instance_segmenter.h>

#include <nlohmann/json.hpp>

#include <cstddef>
#include <vector>

namespace cuefusion
{
namespace cli
{
/** \brief Per frame of a run: poses, reports and every stage's time. */
struct RunOutputs
{
  io::Trajectory trajectory;            ///< accepted poses
  io::Trajectory reference;             ///< the sequence's own poses, where it has them
  std::vector<reconstruction::FrameReport> reports;
  std::vector<pipeline::SegmentationTimings> segmentation;  ///< per segmented frame
  std::vector<std::size_t> volume_bytes;  ///< after each frame: memory growth over the run
  std::vector<double> loop_ms;            ///< per segmented frame: every stage, the mask source excluded
  std::vector<double> read_ms;            ///< per frame: reading and decoding its files (recorded sequences)
  std::vector<double> masks_ms;           ///< per frame: the mask source (the network) on it; 0 without one
  std::vector<recognition::SegmenterTimings> masks_stages;  ///< per frame: the network's input, forward pass, decoding
  std::vector<double> wall_ms;            ///< per frame: from the previous frame's end to this one's
  std::size_t frames_without_masks = 0;
  std::size_t merges = 0;
};

/** \brief Peak resident memory of this process so far, MiB. */
double
peakMemoryMiB ();

/** \brief timings.json: per frame every stage (reading, the mask source and its stages, the
  * loop's stages, the wall time), their medians and 90th percentiles, the run's frames per
  * second (frames / \a seconds), the peak memory. */
nlohmann::json
timingsJson (const RunOutputs& run, double seconds);
}  // namespace cli
}  // namespace cuefusion
