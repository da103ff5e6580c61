// SPDX-License-Identifier: BSD-3-Clause
#pragma once

#include <cuefusion/common/instance.h>
#include <cuefusion/io/pose_io.h>
#include <cuefusion/pipeline/fusion_pipeline.h>

#include <nlohmann/json.hpp>

#include <cstddef>
#include <optional>
#include <string>
#include <vector>

namespace cuefusion
{
namespace pipeline
{
/** \brief What a run measured frame by frame: poses, reports and every stage's time.
  * `cuefusion run` keeps one; tracking.json and timings.json are written from it. */
struct RunRecord
{
  io::Trajectory trajectory;            ///< accepted poses
  io::Trajectory reference;             ///< the sequence's own poses, where it has them
  std::vector<reconstruction::FrameReport> reports;
  std::vector<SegmentationTimings> segmentation;  ///< per segmented frame
  std::vector<std::size_t> volume_bytes;  ///< after each frame: memory growth over the run
  std::vector<double> loop_ms;            ///< per segmented frame: PipelineFrameReport::loop_ms (the mask source excluded)
  std::vector<double> read_ms;            ///< per frame: reading and decoding its files (recorded sequences)
  std::vector<double> masks_ms;           ///< per frame: the mask source (the network) on it; 0 without one
  std::vector<SegmenterTimings> masks_stages;  ///< per frame: the network's input, forward pass, decoding
  std::vector<double> wall_ms;            ///< per frame: from the previous frame's end to this one's
  std::size_t frames_without_masks = 0;
  std::size_t merges = 0;
};

/** \brief The median, 90th percentile and count of \a values (milliseconds), as every
  * timings file gives a stage: {"median", "p90", "frames"}; null figures when empty. */
nlohmann::json
timingSummary (std::vector<double> values);

/** \brief Peak resident memory of this process so far, MiB. */
double
peakMemoryMiB ();

/** \brief timings.json: per frame every stage (reading, the mask source and its stages,
  * the loop's stages, the wall time), their timingSummary, the run's frames per second
  * (frames / \a seconds) and the process's peak memory. */
nlohmann::json
timingsJson (const RunRecord& run, double seconds);

/** \brief Camera accuracy against the sequence's own poses, as tracking.json records it. */
struct TrackingAccuracy
{
  double rmse = 0.0, mean = 0.0, median = 0.0, max = 0.0;
  std::size_t pairs = 0;
};

/** \brief tracking.json beyond the run's record: where its masks came from, the map it
  * continued, its ATE against the sequence's poses (the caller's evaluation). */
struct TrackingFileContext
{
  std::string mask_source;                  ///< the source's name; "" without one
  std::string continued_from;               ///< the loaded volume; "" for a new map
  std::optional<TrackingAccuracy> ate;
};

/** \brief tracking.json: frames, tracked, the lost frames with their reasons, the
  * relocalised ones, the tracking mode, the segmentation (mode, mask source, frames
  * without masks, merges, noise scale), the volume (blocks, bytes, voxel size,
  * truncation), and \a context's parts. */
nlohmann::json
trackingJson (const RunRecord& run, const FusionPipeline& pipeline, const TrackingFileContext& context);

/** \brief outputs.json's record of a run: what ran, on what, how far, with which settings
  * and network, and which files the set holds (written last, it marks the set complete). */
struct RunManifest
{
  std::string sequence;                  ///< as given
  std::size_t frames = 0;
  double seconds = 0.0;                  ///< processing: opening the sequence to the last frame
  bool stopped_early = false;            ///< a recorded sequence cut short by a signal or a closed window
  std::vector<std::string> files;        ///< the set's files written before outputs.json
  std::vector<std::string> command_line; ///< `cuefusion run` and its arguments as given
  std::string working_directory;         ///< what the arguments are relative to
  nlohmann::json config;                 ///< the settings as one settings file (`run --config outputs.json` takes them)
  std::string model_path, model_sha256;  ///< the network by its bytes; empty without one
};

/** \brief outputs.json of \a manifest (with the library's version). */
nlohmann::json
outputsJson (const RunManifest& manifest);

/** \brief What a run folder's outputs.json, tracking.json and timings.json say, for
  * summaries and the evaluation; each figure absent where its file or field is (folders of
  * older versions, or written by Pipeline.save). Throws cuefusion::Error naming a file that
  * is there but no JSON. */
struct RunFilesSummary
{
  bool has_manifest = false;            ///< outputs.json is there (the set is complete)
  bool stopped_early = false;           ///< outputs.json: a signal cut the sequence short
  std::optional<double> frames, seconds;  ///< outputs.json
  std::optional<double> tracked, lost;    ///< tracking.json
  std::optional<double> ate_rmse;         ///< tracking.json, metres
  std::optional<double> voxel_size;       ///< tracking.json, metres
  std::optional<double> loop_ms;          ///< timings.json: the whole loop's median
};

/** \brief Which of a run folder's record files readRunFiles reads (or-ed). */
enum RunFile : unsigned
{
  kManifestFile = 1,  ///< outputs.json
  kTrackingFile = 2,  ///< tracking.json
  kTimingsFile = 4,   ///< timings.json
  kAllRunFiles = 7
};

/** \brief Reads \a files of the run folder \a dir (the others' figures stay absent, and
  * a broken file that was not asked for is no error). */
RunFilesSummary
readRunFiles (const std::string& dir, unsigned files = kAllRunFiles);
}  // namespace pipeline
}  // namespace cuefusion
