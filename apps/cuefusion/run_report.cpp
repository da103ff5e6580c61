// SPDX-License-Identifier: BSD-3-Clause
#include "run_report.h"
#include "cli.h"

#include <sys/resource.h>

namespace cuefusion
{
namespace cli
{
// Linux reports ru_maxrss in KiB.
double
peakMemoryMiB ()
{
  rusage usage{};
  getrusage (RUSAGE_SELF, &usage);
  return static_cast<double> (usage.ru_maxrss) / 1024.0;
}

namespace
{
/** One stage of the network over the frames that ran it (a source that does not time its
  * stages gives none). */
std::vector<double>
maskStage (const RunOutputs& run, double recognition::SegmenterTimings::*stage)
{
  std::vector<double> out;
  for (const recognition::SegmenterTimings& t : run.masks_stages)
    if (t.input_ms + t.forward_ms + t.decode_ms > 0.0)
      out.push_back (t.*stage);
  return out;
}
}  // namespace

nlohmann::json
timingsJson (const RunOutputs& run, double seconds)
{
  const std::vector<reconstruction::FrameReport>& reports = run.reports;
  const auto at = [] (const std::vector<double>& v, std::size_t k) { return k < v.size () ? v[k] : 0.0; };
  std::vector<double> pre, track, integrate, raycast, core, relocalise, lost;
  nlohmann::json frames = nlohmann::json::array ();
  for (std::size_t k = 0; k < reports.size (); ++k)
  {
    const auto& r = reports[k];
    const auto& t = r.timings;
    const recognition::SegmenterTimings stages = k < run.masks_stages.size () ? run.masks_stages[k] : recognition::SegmenterTimings ();
    frames.push_back ({{"index", r.index}, {"read_ms", at (run.read_ms, k)}, {"masks_ms", at (run.masks_ms, k)},
                       {"masks_input_ms", stages.input_ms}, {"masks_forward_ms", stages.forward_ms}, {"masks_decode_ms", stages.decode_ms},
                       {"preprocess_ms", t.preprocess_ms}, {"track_ms", t.track_ms},
                       {"integrate_ms", t.integrate_ms}, {"raycast_ms", t.raycast_ms}, {"relocalise_ms", t.relocalise_ms},
                       {"wall_ms", at (run.wall_ms, k)},
                       {"volume_mib", k < run.volume_bytes.size () ? static_cast<double> (run.volume_bytes[k]) / (1024.0 * 1024.0) : 0.0}});
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
                      {"masks", timingSummary (run.masks_ms)}, {"masks: input", timingSummary (maskStage (run, &recognition::SegmenterTimings::input_ms))},
                      {"masks: forward", timingSummary (maskStage (run, &recognition::SegmenterTimings::forward_ms))},
                      {"masks: decode", timingSummary (maskStage (run, &recognition::SegmenterTimings::decode_ms))},
                      {"wall per frame", timingSummary (run.wall_ms)}}},
          {"frames_per_second", seconds > 0.0 ? static_cast<double> (reports.size ()) / seconds : 0.0},
          {"peak_memory_mib", peakMemoryMiB ()},
          {"frames", frames}};
}
}  // namespace cli
}  // namespace cuefusion
