// SPDX-License-Identifier: BSD-3-Clause
// A run's record files, written and read here only: timings.json and tracking.json (what
// `cuefusion run` measured), and the summary batch and eval read back from a run folder.
#include <cuefusion/pipeline/run_files.h>

#include <cuefusion/common/exceptions.h>
#include <cuefusion/common/data_directory.h>
#include <cuefusion/io/file_io.h>

#include <boost/filesystem.hpp>
#include <sys/resource.h>

#include <algorithm>

namespace fs = boost::filesystem;

namespace cuefusion
{
namespace pipeline
{
namespace
{
/** One stage of the network over the frames that ran it (a source that does not time its
  * stages gives none). */
std::vector<double>
maskStage (const RunRecord& run, double SegmenterTimings::*stage)
{
  std::vector<double> out;
  for (const SegmenterTimings& t : run.masks_stages)
    if (t.input_ms + t.forward_ms + t.decode_ms > 0.0)
      out.push_back (t.*stage);
  return out;
}

/** The frames' own figures, timings.json's "frames" list. */
nlohmann::json
frameTimings (const RunRecord& run)
{
  const auto at = [] (const std::vector<double>& v, std::size_t k) { return k < v.size () ? v[k] : 0.0; };
  nlohmann::json frames = nlohmann::json::array ();
  for (std::size_t k = 0; k < run.reports.size (); ++k)
  {
    const reconstruction::FrameReport& r = run.reports[k];
    const auto& t = r.timings;
    const SegmenterTimings stages = k < run.masks_stages.size () ? run.masks_stages[k] : SegmenterTimings ();
    frames.push_back ({{"index", r.index}, {"read_ms", at (run.read_ms, k)}, {"masks_ms", at (run.masks_ms, k)},
                       {"masks_input_ms", stages.input_ms}, {"masks_forward_ms", stages.forward_ms}, {"masks_decode_ms", stages.decode_ms},
                       {"preprocess_ms", t.preprocess_ms}, {"track_ms", t.track_ms},
                       {"integrate_ms", t.integrate_ms}, {"raycast_ms", t.raycast_ms}, {"relocalise_ms", t.relocalise_ms},
                       {"wall_ms", at (run.wall_ms, k)},
                       {"volume_mib", k < run.volume_bytes.size () ? static_cast<double> (run.volume_bytes[k]) / (1024.0 * 1024.0) : 0.0}});
  }
  return frames;
}

/** A JSON file when it is there, else null; a file that is there but no JSON throws. */
nlohmann::json
jsonIfPresent (const fs::path& path)
{
  boost::system::error_code ec;
  if (!fs::is_regular_file (path, ec))
    return nullptr;
  return io::readJsonFile (path.string ());
}

std::optional<double>
numberAt (const nlohmann::json& json, const std::string& key)
{
  if (!json.is_object ())
    return std::nullopt;
  const auto it = json.find (key);
  return it != json.end () && it->is_number () ? std::optional<double> (it->get<double> ()) : std::nullopt;
}
}  // namespace

nlohmann::json
timingSummary (std::vector<double> values)
{
  if (values.empty ())
    return {{"median", nullptr}, {"p90", nullptr}, {"frames", 0}};
  std::sort (values.begin (), values.end ());
  const auto at = [&values] (double q) {
    return values[static_cast<std::size_t> (q * static_cast<double> (values.size () - 1) + 0.5)];
  };
  return {{"median", at (0.5)}, {"p90", at (0.9)}, {"frames", values.size ()}};
}

// Linux reports ru_maxrss in KiB.
double
peakMemoryMiB ()
{
  rusage usage{};
  getrusage (RUSAGE_SELF, &usage);
  return static_cast<double> (usage.ru_maxrss) / 1024.0;
}

nlohmann::json
timingsJson (const RunRecord& run, double seconds)
{
  std::vector<double> pre, track, integrate, raycast, core, relocalise, lost;
  for (const reconstruction::FrameReport& r : run.reports)
  {
    const auto& t = r.timings;
    if (t.relocalise_ms > 0.0)  // frames whose tracking failed, relocalised or not
      relocalise.push_back (t.relocalise_ms);
    if (!r.tracked)
    {
      lost.push_back (t.preprocess_ms + t.track_ms + t.relocalise_ms);  // all a lost frame costs
      continue;
    }
    pre.push_back (t.preprocess_ms);
    track.push_back (t.track_ms);
    integrate.push_back (t.integrate_ms);
    raycast.push_back (t.raycast_ms);
    core.push_back (t.track_ms + t.integrate_ms + t.raycast_ms);
  }
  std::vector<double> geometry, instances, propagation, merging, update, segmentation_total;
  for (const auto& t : run.segmentation)
  {
    geometry.push_back (t.geometry_ms);
    instances.push_back (t.instances_ms);
    propagation.push_back (t.propagation_ms);
    merging.push_back (t.merging_ms);
    update.push_back (t.update_ms);
    segmentation_total.push_back (t.total ());
  }
  return {{"stages", {{"preprocess", timingSummary (pre)}, {"track", timingSummary (track)}, {"integrate", timingSummary (integrate)},
                      {"raycast", timingSummary (raycast)}, {"track+integrate+raycast", timingSummary (core)},
                      {"relocalise (lost frames only)", timingSummary (relocalise)},
                      {"lost frame (preprocess+track+relocalise)", timingSummary (lost)},
                      {"geometric segmentation", timingSummary (geometry)}, {"instance merge", timingSummary (instances)},
                      {"propagation", timingSummary (propagation)}, {"segment merging", timingSummary (merging)},
                      {"label update", timingSummary (update)}, {"segmentation", timingSummary (segmentation_total)},
                      {"whole loop", timingSummary (run.loop_ms)}, {"read", timingSummary (run.read_ms)},
                      {"masks", timingSummary (run.masks_ms)}, {"masks: input", timingSummary (maskStage (run, &SegmenterTimings::input_ms))},
                      {"masks: forward", timingSummary (maskStage (run, &SegmenterTimings::forward_ms))},
                      {"masks: decode", timingSummary (maskStage (run, &SegmenterTimings::decode_ms))},
                      {"wall per frame", timingSummary (run.wall_ms)}}},
          {"frames_per_second", seconds > 0.0 ? static_cast<double> (run.reports.size ()) / seconds : 0.0},
          {"peak_memory_mib", peakMemoryMiB ()},
          {"frames", frameTimings (run)}};
}

nlohmann::json
trackingJson (const RunRecord& run, const FusionPipeline& pipeline, const TrackingFileContext& context)
{
  const reconstruction::TSDFVolume& volume = pipeline.reconstruction ().volume ();
  nlohmann::json lost = nlohmann::json::array ();
  for (const auto& r : run.reports)
    if (!r.tracked)
      lost.push_back ({{"index", r.index}, {"timestamp", r.timestamp}, {"reason", r.failure}});
  nlohmann::json relocalised = nlohmann::json::array ();
  for (const auto& r : run.reports)
    if (r.relocalised)
      relocalised.push_back ({{"index", r.index}, {"timestamp", r.timestamp}, {"from", r.relocalised_from},
                              {"ms", r.timings.relocalise_ms}});
  nlohmann::json tracking;
  tracking["frames"] = run.reports.size ();
  tracking["tracked"] = run.trajectory.size ();
  tracking["lost"] = lost;
  tracking["relocalised"] = relocalised;
  tracking["mode"] = pipeline.reconstruction ().getConfig ().use_reference_poses ? "reference poses" : "frame-to-model ICP";
  tracking["segmentation"] = {{"mode", segmentationModeName (pipeline.getConfig ().mode)},
                              {"mask_source", context.mask_source},
                              {"frames_without_masks", run.frames_without_masks},
                              {"merges", run.merges},
                              {"noise_scale", pipeline.noiseScale ()}};
  tracking["volume"] = {{"blocks", volume.blockCount ()}, {"bytes", volume.memoryUsage ()},
                        {"voxel_size", volume.getConfig ().voxel_size}, {"truncation_voxels", volume.getConfig ().truncation_voxels}};
  if (!context.continued_from.empty ())
    tracking["continued_from"] = context.continued_from;
  if (const auto& ate = context.ate)
    tracking["ate"] = {{"rmse", ate->rmse}, {"mean", ate->mean}, {"median", ate->median}, {"max", ate->max}, {"pairs", ate->pairs}};
  return tracking;
}

nlohmann::json
outputsJson (const RunManifest& manifest)
{
  nlohmann::json out = {{"command", "run"},
                        {"version", version ()},
                        {"sequence", manifest.sequence},
                        {"frames", manifest.frames},
                        {"seconds", manifest.seconds},
                        {"complete", true},
                        {"stopped_early", manifest.stopped_early},
                        {"files", manifest.files},
                        {"command_line", manifest.command_line},
                        {"working_directory", manifest.working_directory},
                        {"config", manifest.config}};
  if (!manifest.model_path.empty ())
    out["model"] = {{"path", manifest.model_path}, {"sha256", manifest.model_sha256}};
  return out;
}

RunFilesSummary
readRunFiles (const std::string& dir, unsigned files)
{
  const fs::path folder (dir);
  RunFilesSummary summary;
  if (files & kManifestFile)
  {
    const nlohmann::json outputs = jsonIfPresent (folder / "outputs.json");
    summary.has_manifest = outputs.is_object ();
    summary.stopped_early = outputs.is_object () && outputs.value ("stopped_early", false);
    summary.frames = numberAt (outputs, "frames");
    summary.seconds = numberAt (outputs, "seconds");
  }
  if (files & kTrackingFile)
  {
    const nlohmann::json tracking = jsonIfPresent (folder / "tracking.json");
    summary.tracked = numberAt (tracking, "tracked");
    if (tracking.is_object () && tracking.contains ("lost") && tracking["lost"].is_array ())
      summary.lost = static_cast<double> (tracking["lost"].size ());
    if (tracking.is_object () && tracking.contains ("ate"))
      summary.ate_rmse = numberAt (tracking["ate"], "rmse");
    if (tracking.is_object () && tracking.contains ("volume"))
      summary.voxel_size = numberAt (tracking["volume"], "voxel_size");
  }
  if (files & kTimingsFile)
  {
    const nlohmann::json timings = jsonIfPresent (folder / "timings.json");
    if (timings.is_object () && timings.contains ("stages") && timings["stages"].is_object () && timings["stages"].contains ("whole loop"))
      summary.loop_ms = numberAt (timings["stages"]["whole loop"], "median");
  }
  return summary;
}
}  // namespace pipeline
}  // namespace cuefusion
