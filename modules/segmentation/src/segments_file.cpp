// SPDX-License-Identifier: BSD-3-Clause
// segments.json: written by `cuefusion run`, read by `cuefusion eval` (segments_file.h).
#include <cuefusion/segmentation/fragmentation.h>
#include <cuefusion/segmentation/segments_file.h>

#include <cuefusion/common/exceptions.h>
#include <cuefusion/io/file_io.h>

#include <nlohmann/json.hpp>

#include <algorithm>
#include <limits>
#include <set>

namespace cuefusion
{
namespace segmentation
{
namespace
{
/** A vector as a JSON list. */
nlohmann::json
jsonVector (const Eigen::Vector3f& v)
{
  return {v.x (), v.y (), v.z ()};
}
}  // namespace

std::string
segmentsJsonText (const std::vector<SegmentRecord>& segments, const std::map<std::uint32_t, ObjectGeometry>& geometry)
{
  // A score is the detector's confidence in a segment. Where the masks claimed something in
  // this run, a segment they gave no class (never claimed, or in under a quarter of its
  // frames) has none of it: 0, so that 3D AP ranks it after every segment the masks
  // support. Before, its null tied at the top in `eval`, above them all: with a network
  // out of its domain (tabletop-trained, whole rooms) the pieces of cabinets and walls
  // the masks did not support outranked the objects they did. Without any claim (a
  // geometry run) every score stays null, and all rank alike.
  const bool detector_spoke =
      std::any_of (segments.begin (), segments.end (), [] (const SegmentRecord& s) { return !s.class_votes.empty (); });
  nlohmann::json list = nlohmann::json::array ();
  for (const auto& s : segments)
  {
    nlohmann::json entry = {{"id", s.id},
                            {"voxels", s.voxels},
                            {"first_frame", s.first_frame},
                            {"last_frame", s.last_frame},
                            {"frames_seen", s.frames_seen},
                            {"loaded", s.loaded},
                            {"bounds", {{"min", {s.bounds.min ().x (), s.bounds.min ().y (), s.bounds.min ().z ()}},
                                        {"max", {s.bounds.max ().x (), s.bounds.max ().y (), s.bounds.max ().z ()}}}}};
    const std::string best = s.bestClass ();
    entry["class"] = best.empty () ? nlohmann::json (nullptr) : nlohmann::json (best);
    entry["score"] = !best.empty () ? nlohmann::json (s.bestScore ()) : detector_spoke ? nlohmann::json (0.0) : nlohmann::json (nullptr);
    nlohmann::json votes = nlohmann::json::object ();
    for (const auto& [name, vote] : s.class_votes)
      votes[name] = vote.first;
    entry["class_votes"] = votes;
    const auto g = geometry.find (s.id);
    if (g != geometry.end ())
    {
      const OrientedBox& box = g->second.box;
      entry["points"] = g->second.points;
      entry["centroid"] = jsonVector (g->second.centroid);
      entry["oriented_box"] = {{"center", jsonVector (box.center)},
                               {"axes", {jsonVector (box.axes.col (0)), jsonVector (box.axes.col (1)), jsonVector (box.axes.col (2))}},
                               {"extents", jsonVector (box.extents)}};
    }
    else
    {
      entry["points"] = 0;
      entry["centroid"] = nullptr;
      entry["oriented_box"] = nullptr;
    }
    list.push_back (entry);
  }
  const FragmentationReport f = fragmentationReport (segments);
  nlohmann::json classes = nlohmann::json::array ();
  const char* names[] = {"below 100", "100 to 999", "1000 to 9999", "10000 or more"};
  for (std::size_t k = 0; k < f.count_by_size.size (); ++k)
    classes.push_back ({{"voxels", names[k]}, {"segments", f.count_by_size[k]}, {"share_of_surface", f.share_by_size[k]}});
  const nlohmann::json fragmentation = {{"segments", f.segments},
                                        {"voxels", f.voxels},
                                        {"segments_at_least_100_voxels", f.segments_at_least_100 ()},
                                        {"share_of_surface_below_100_voxels", f.shareBelow (100)},
                                        {"share_of_surface_below_1000_voxels", f.shareBelow (1000)},
                                        {"by_size", classes}};
  const nlohmann::json doc = {{"segments", list}, {"fragmentation", fragmentation}};
  return io::jsonText (doc, 1) + "\n";
}

void
writeSegmentsJson (const std::string& path, const std::vector<SegmentRecord>& segments,
                   const std::map<std::uint32_t, ObjectGeometry>& geometry)
{
  io::writeTextAtomic (path, segmentsJsonText (segments, geometry));
}

std::vector<SegmentEntry>
readSegmentsJson (const std::string& path)
{
  const FileContext context (path);
  const nlohmann::json doc = io::readJsonFile (path);
  if (!doc.is_object () || !doc.contains ("segments") || !doc.at ("segments").is_array ())
    throw Error (path, "malformed segments.json: no list \"segments\"");
  std::vector<SegmentEntry> entries;
  std::set<std::uint32_t> seen;
  for (const nlohmann::json& s : doc.at ("segments"))
  {
    const auto bad = [&] (const std::string& what) { return Error (path, "malformed segments.json: " + what); };
    if (!s.is_object () || !s.contains ("id") || !s.at ("id").is_number_unsigned () || s.at ("id").get<std::uint64_t> () == 0 ||
        s.at ("id").get<std::uint64_t> () > std::numeric_limits<std::uint32_t>::max ())
      throw bad ("every segment needs an integer \"id\" in [1, 2^32), got " +
                 (s.is_object () && s.contains ("id") ? io::jsonText (s.at ("id")) : std::string ("none")));
    SegmentEntry entry;
    entry.id = s.at ("id").get<std::uint32_t> ();
    if (!seen.insert (entry.id).second)
      throw bad ("segment id " + std::to_string (entry.id) + " appears twice");
    if (s.contains ("class") && !s.at ("class").is_null ())
    {
      if (!s.at ("class").is_string ())
        throw bad ("segment " + std::to_string (entry.id) + ": \"class\" must be a string or null");
      entry.class_name = s.at ("class").get<std::string> ();
    }
    if (s.contains ("score") && !s.at ("score").is_null ())
    {
      entry.score = s.at ("score").is_number () ? s.at ("score").get<double> () : -1.0;
      if (!(entry.score >= 0.0 && entry.score <= 1.0))
        throw bad ("segment " + std::to_string (entry.id) + ": \"score\" must be a number in [0, 1] or null, got " +
                   io::jsonText (s.at ("score")));
    }
    entries.push_back (entry);
  }
  return entries;
}
}  // namespace segmentation
}  // namespace cuefusion
