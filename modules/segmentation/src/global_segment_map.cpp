// SPDX-License-Identifier: BSD-3-Clause
#include <cuefusion/common/exceptions.h>
#include <cuefusion/reconstruction/tsdf_volume.h>
#include <cuefusion/segmentation/global_segment_map.h>

#include "coplanar_surfaces.h"

#include <algorithm>
#include <atomic>
#include <set>

namespace cuefusion
{
namespace segmentation
{
std::uint32_t
LabelEquivalence::find (std::uint32_t label) const
{
  // Read-only, so threads may resolve labels concurrently; compact() keeps chains short.
  while (label < parent_.size () && parent_[label] != label)
    label = parent_[label];
  return label;
}

void
LabelEquivalence::compact ()
{
  for (std::size_t i = 0; i < parent_.size (); ++i)
    parent_[i] = find (parent_[i]);
}

std::uint32_t
LabelEquivalence::unite (std::uint32_t a, std::uint32_t b)
{
  std::uint32_t ra = find (a), rb = find (b);
  if (ra == rb || ra == 0 || rb == 0)
    return ra;
  if (rb < ra)
    std::swap (ra, rb);
  const std::size_t needed = static_cast<std::size_t> (rb) + 1;
  for (std::size_t i = parent_.size (); i < needed; ++i)
    parent_.push_back (static_cast<std::uint32_t> (i));
  parent_[rb] = ra;
  return ra;
}

void
GlobalSegmentMapConfig::validate () const
{
  if (confirm_confidence < 1 || confirm_confidence > 1000)
    throw ParameterError ("GlobalSegmentMapConfig::confirm_confidence", "must lie in [1, 1000]");
  if (!(together_share >= 0.f && together_share < 1.f))
    throw ParameterError ("GlobalSegmentMapConfig::together_share", "must lie in [0, 1)");
  if (!(confirm_share >= 0.f && confirm_share < 1.f))
    throw ParameterError ("GlobalSegmentMapConfig::confirm_share", "must lie in [0, 1)");
  if (!(surface_min_extent >= 0.f && surface_min_extent <= 100.f))
    throw ParameterError ("GlobalSegmentMapConfig::surface_min_extent", "must lie in [0, 100] (metres; 0 = off)");
  if (!(surface_tolerance > 0.f && surface_tolerance <= 1.f))
    throw ParameterError ("GlobalSegmentMapConfig::surface_tolerance", "must lie in (0, 1] (metres)");
  if (!(surface_max_angle_deg >= 0.f && surface_max_angle_deg < 90.f))
    throw ParameterError ("GlobalSegmentMapConfig::surface_max_angle_deg", "must lie in [0, 90)");
}

PairEvidence::PairEvidence (const GlobalSegmentMapConfig& config) : config_ (config) { config_.validate (); }

bool
PairEvidence::add (std::uint32_t a, std::uint32_t b, PairVote vote)
{
  if (a == b || a == 0 || b == 0)
    return false;
  Counts& c = counts_[{std::min (a, b), std::max (a, b)}];
  const bool before = united (c);
  ++(vote == PairVote::Together ? c.together : c.apart);
  return united (c) != before;
}

PairEvidence::Counts
PairEvidence::counts (std::uint32_t a, std::uint32_t b) const
{
  const auto it = counts_.find ({std::min (a, b), std::max (a, b)});
  return it == counts_.end () ? Counts () : it->second;
}

bool
PairEvidence::united (const Counts& c) const
{
  return c.together >= config_.confirm_confidence &&
         static_cast<float> (c.together) > config_.together_share * static_cast<float> (c.together + c.apart);
}

bool
PairEvidence::united (std::uint32_t a, std::uint32_t b) const
{
  return united (counts (a, b));
}

bool
PairEvidence::tracked (std::uint32_t a, std::uint32_t b) const
{
  return counts_.count ({std::min (a, b), std::max (a, b)}) != 0;
}

std::string
SegmentRecord::bestClass () const
{
  std::string best;
  std::pair<int, float> best_vote (0, 0.f);
  for (const auto& [name, vote] : class_votes)
    if (vote.first > best_vote.first || (vote.first == best_vote.first && vote.second > best_vote.second))
    {
      best = name;
      best_vote = vote;
    }
  return 4 * static_cast<std::size_t> (best_vote.first) >= frames_seen ? best : std::string ();
}

float
SegmentRecord::bestScore () const
{
  const auto it = class_votes.find (bestClass ());
  return it == class_votes.end () || it->second.first == 0 ? 0.f : it->second.second / static_cast<float> (it->second.first);
}

GlobalSegmentMap::GlobalSegmentMap (const GlobalSegmentMapConfig& merging) : evidence_ (merging) {}

std::uint32_t
GlobalSegmentMap::newSegment (std::size_t frame)
{
  const std::uint32_t label = next_label_++;
  SegmentRecord& record = records_[label];
  record.id = label;
  record.first_frame = record.last_frame = frame;
  latest_frame_ = std::max (latest_frame_, frame);
  return label;
}

std::uint32_t
GlobalSegmentMap::newLoadedSegment (std::size_t frame)
{
  const std::uint32_t label = newSegment (frame);
  records_[label].loaded = true;
  return label;
}

const std::vector<std::uint32_t>&
GlobalSegmentMap::successors (std::uint32_t label) const
{
  static const std::vector<std::uint32_t> none;
  const auto it = successors_.find (label);
  return it == successors_.end () ? none : it->second;
}

std::uint32_t
GlobalSegmentMap::newSuccessor (std::uint32_t label, std::size_t frame)
{
  const std::uint32_t fresh = newSegment (frame);
  successors_[label].push_back (fresh);
  return fresh;
}

void
GlobalSegmentMap::observe (std::uint32_t label, std::size_t frame, const SegmentInstance* info)
{
  const auto it = records_.find (label);
  if (it == records_.end ())
    return;
  SegmentRecord& record = it->second;
  if (record.frames_seen == 0 || frame != record.last_frame)
    ++record.frames_seen;
  record.last_frame = std::max (record.last_frame, frame);
  latest_frame_ = std::max (latest_frame_, frame);
  if (info && info->instance >= 0 && !info->class_name.empty ())
  {
    auto& vote = record.class_votes[info->class_name];
    ++vote.first;
    vote.second += info->score;
  }
}

void
GlobalSegmentMap::regroup ()
{
  equivalence_.clear ();
  for (const auto& [pair, counts] : evidence_.pairs ())
    if (evidence_.united (counts))
      equivalence_.unite (pair.first, pair.second);
  for (const auto& [a, b] : pinned_)
    equivalence_.unite (a, b);
  equivalence_.compact ();
}

std::size_t
GlobalSegmentMap::addEvidence (const std::vector<std::tuple<std::uint32_t, std::uint32_t, PairVote>>& votes)
{
  if (votes.empty ())
    return 0;
  // The grouping changes only when some pair's verdict does.
  bool changed_verdict = false;
  for (const auto& [a, b, vote] : votes)
    changed_verdict = evidence_.add (a, b, vote) || changed_verdict;
  if (!changed_verdict)
    return 0;
  std::vector<std::uint32_t> roots_before (next_label_);
  for (std::uint32_t l = 0; l < next_label_; ++l)
    roots_before[l] = resolve (l);
  regroup ();
  std::size_t changed = 0;
  for (std::uint32_t l = 1; l < next_label_; ++l)
    changed += resolve (l) != roots_before[l] ? 1 : 0;
  return changed;
}

std::uint32_t
GlobalSegmentMap::merge (std::uint32_t a, std::uint32_t b)
{
  if (a == 0 || b == 0)
    return resolve (a);
  pinned_.emplace_back (a, b);
  regroup ();
  return resolve (a);
}

void
GlobalSegmentMap::refreshStatistics (const reconstruction::TSDFVolume& volume, const VoxelLabelLayer& labels)
{
  for (auto& [label, record] : records_)
  {
    record.voxels = 0;
    record.bounds.setEmpty ();
  }
  const reconstruction::VoxelBlockStore& blocks = volume.store ();
  for (std::size_t id = 0; id < std::min (blocks.size (), labels.blockCount ()); ++id)
    for (int z = 0; z < reconstruction::kBlockSide; ++z)
      for (int y = 0; y < reconstruction::kBlockSide; ++y)
        for (int x = 0; x < reconstruction::kBlockSide; ++x)
        {
          const auto local = static_cast<std::size_t> (reconstruction::localVoxelIndex (x, y, z));
          const std::uint32_t label = labels.block (id).labels[local];
          if (blocks.block (id).voxels[local].weight <= 0.f || label == 0)
            continue;
          const auto it = records_.find (label);
          if (it == records_.end ())
            continue;
          ++it->second.voxels;
          it->second.bounds.extend (volume.voxelPosition (blocks.block (id).index * reconstruction::kBlockSide + Eigen::Vector3i (x, y, z)));
        }
}

namespace
{
/** \brief The votes on pairs of labels summed per pair of the objects \a shown gives their
  * labels (label → object, 0 none), by (smaller, larger) object; pairs within one object
  * are left out. */
std::map<std::pair<std::uint32_t, std::uint32_t>, PairEvidence::Counts>
votesByObject (const PairEvidence& evidence, const std::vector<std::uint32_t>& shown)
{
  std::map<std::pair<std::uint32_t, std::uint32_t>, PairEvidence::Counts> sums;
  for (const auto& [pair, counts] : evidence.pairs ())
  {
    const std::uint32_t a = pair.first < shown.size () ? shown[pair.first] : 0, b = pair.second < shown.size () ? shown[pair.second] : 0;
    if (a == 0 || b == 0 || a == b)
      continue;
    PairEvidence::Counts& sum = sums[{std::min (a, b), std::max (a, b)}];
    sum.together += counts.together;
    sum.apart += counts.apart;
  }
  return sums;
}

/** \brief \a source's frames, class votes, voxels and bounds added to \a target. */
void
combine (SegmentRecord& target, const SegmentRecord& source)
{
  target.first_frame = std::min (target.first_frame, source.first_frame);
  target.last_frame = std::max (target.last_frame, source.last_frame);
  target.frames_seen = std::max (target.frames_seen, source.frames_seen);
  target.loaded = target.loaded || source.loaded;
  for (const auto& [name, vote] : source.class_votes)
  {
    auto& v = target.class_votes[name];
    v.first += vote.first;
    v.second += vote.second;
  }
  target.voxels += source.voxels;
  target.bounds.extend (source.bounds);
}
}  // namespace

std::vector<SegmentRecord>
GlobalSegmentMap::segments (const std::unordered_map<std::uint32_t, std::uint32_t>* settled) const
{
  std::map<std::uint32_t, SegmentRecord> objects;  // by the object's label
  for (const auto& [label, record] : records_)
  {
    std::uint32_t target = resolve (label);
    if (settled)
    {
      const auto it = settled->find (label);
      target = it == settled->end () ? 0 : it->second;
      if (target == 0)
        continue;
    }
    const auto it = objects.find (target);
    if (it == objects.end ())
    {
      SegmentRecord& r = objects[target];
      r = record;
      r.id = target;
    }
    else
      combine (it->second, record);
  }
  std::vector<SegmentRecord> out;
  for (auto& [id, record] : objects)
    out.push_back (std::move (record));
  return out;
}

namespace
{
/** \brief Per object (label resolved by \a resolve): the mean TSDF weight of its voxels,
  * which counts the frames that observed them (one per integration, up to w_max).
  */
template <class Resolve>
std::unordered_map<std::uint32_t, double>
meanObservations (const reconstruction::VoxelBlockStore& blocks, const VoxelLabelLayer& labels, const Resolve& resolve)
{
  std::unordered_map<std::uint32_t, std::pair<double, std::size_t>> sums;
  for (std::size_t id = 0; id < std::min (blocks.size (), labels.blockCount ()); ++id)
    for (int i = 0; i < reconstruction::kBlockVoxels; ++i)
    {
      const std::uint32_t label = labels.block (id).labels[static_cast<std::size_t> (i)];
      const float weight = blocks.block (id).voxels[static_cast<std::size_t> (i)].weight;
      if (weight <= 0.f || label == 0)
        continue;
      auto& sum = sums[resolve (label)];
      sum.first += weight;
      ++sum.second;
    }
  std::unordered_map<std::uint32_t, double> out;
  for (const auto& [object, sum] : sums)
    out[object] = sum.first / static_cast<double> (sum.second);
  return out;
}

/** \brief Per label below \a label_end: whether the map's surface shows it, i.e. it is the
  * label of the nearer voxel of some zero crossing (the voxel that labels the crossing's
  * point in map.pcd and the mesh; TSDFVolume::extractPointCloud, one source of the rule).
  */
std::vector<bool>
labelsOnSurface (const reconstruction::TSDFVolume& volume, const VoxelLabelLayer& labels, std::uint32_t label_end)
{
  // Atomic: the extraction calls back from several threads.
  std::vector<std::atomic<bool>> shown (label_end);
  pcl::PointCloud<pcl::PointXYZRGBL> cloud;
  volume.extractPointCloud (cloud, nullptr, [&] (reconstruction::VoxelNumber v) {
    const std::uint32_t label = labels.label (v);
    if (label < label_end)
      shown[label].store (true, std::memory_order_relaxed);
    return 0u;
  });
  std::vector<bool> out (label_end);
  for (std::uint32_t l = 0; l < label_end; ++l)
    out[l] = shown[l].load (std::memory_order_relaxed);
  return out;
}
}  // namespace

std::unordered_map<std::uint32_t, std::uint32_t>
GlobalSegmentMap::settledLabels (const reconstruction::TSDFVolume& volume, const VoxelLabelLayer& labels) const
{
  const GlobalSegmentMapConfig& config = evidence_.getConfig ();
  const auto confirm = static_cast<std::size_t> (config.confirm_confidence);
  // An object none of whose labels is on the map's surface (they remain only in voxels of
  // the truncation band, in front of or behind surfaces other labels show) cannot be seen
  // in map.pcd or the mesh: it is not confirmed, and settles like a fragment.
  const std::vector<bool> on_surface = labelsOnSurface (volume, labels, next_label_);
  std::unordered_map<std::uint32_t, bool> loaded, recent, surfaced;  // object → loaded, still being seen, some label on the surface
  std::unordered_map<std::uint32_t, std::size_t> most, seen;  // object → frames its most seen label was, all its labels were
  for (const auto& [label, record] : records_)
  {
    const std::uint32_t object = resolve (label);
    loaded[object] = loaded[object] || record.loaded;
    recent[object] = recent[object] || latest_frame_ - record.last_frame < confirm;
    surfaced[object] = surfaced[object] || (label < on_surface.size () && on_surface[label]);
    most[object] = std::max (most[object], record.frames_seen);
    seen[object] += record.frames_seen;
  }
  // Confirmed: loaded, or one of its labels seen in confirm_confidence frames and its
  // labels in confirm_share of the frames that observed its surface (summed: an object
  // whose label changed over the run still counts every frame).
  const std::unordered_map<std::uint32_t, double> observed =
    config.confirm_share > 0.f ? meanObservations (volume.store (), labels, [this] (std::uint32_t l) { return resolve (l); })
                               : std::unordered_map<std::uint32_t, double> ();
  std::unordered_map<std::uint32_t, bool> kept;  // object → confirmed
  for (const auto& [object, frames] : seen)
  {
    const auto it = observed.find (object);
    kept[object] = loaded[object] || (surfaced[object] && most[object] >= confirm &&
                                      (it == observed.end () || static_cast<double> (frames) >= config.confirm_share * it->second));
  }
  std::unordered_map<std::uint32_t, std::uint32_t> target;  // object → what it shows as (fragments: once settled)
  for (const auto& [object, keep] : kept)
    if (keep)
      target[object] = object;
  // The fragments' voxels, gathered in one pass over the volume.
  std::vector<std::pair<Eigen::Vector3i, std::uint32_t>> fragment_voxels;  // (voxel, fragment object)
  const reconstruction::VoxelBlockStore& blocks = volume.store ();
  for (std::size_t id = 0; id < std::min (blocks.size (), labels.blockCount ()); ++id)
    for (int i = 0; i < reconstruction::kBlockVoxels; ++i)
    {
      const std::uint32_t label = labels.block (id).labels[static_cast<std::size_t> (i)];
      if (blocks.block (id).voxels[static_cast<std::size_t> (i)].weight <= 0.f || label == 0)
        continue;
      const std::uint32_t object = resolve (label);
      if (!target.count (object))
        fragment_voxels.emplace_back (blocks.block (id).index * reconstruction::kBlockSide +
                                        reconstruction::localVoxelPosition (i),
                                      object);
    }
  // Fragments take the settled object their voxels touch most; rounds follow chains of
  // fragments (a fragment touching only another fragment settles once that one has).
  constexpr int kRounds = 4;
  const Eigen::Vector3i steps[6] = {{1, 0, 0}, {-1, 0, 0}, {0, 1, 0}, {0, -1, 0}, {0, 0, 1}, {0, 0, -1}};
  for (int round = 0; round < kRounds; ++round)
  {
    std::map<std::uint32_t, std::map<std::uint32_t, std::size_t>> contacts;  // fragment → settled object → voxel faces
    for (const auto& [v, object] : fragment_voxels)
    {
      if (target.count (object))
        continue;
      for (const Eigen::Vector3i& step : steps)
      {
        const reconstruction::VoxelNumber other = blocks.findVoxelNumber (v + step);
        if (other == reconstruction::kNoVoxel)
          continue;
        const std::uint32_t other_label = labels.label (other);
        if (other_label == 0 ||
            blocks.block (other / reconstruction::kBlockVoxels).voxels[other % reconstruction::kBlockVoxels].weight <= 0.f)
          continue;
        const auto settled = target.find (resolve (other_label));
        if (settled != target.end () && settled->second != 0)
          ++contacts[object][settled->second];
      }
    }
    if (contacts.empty ())
      break;
    for (const auto& [fragment, counts] : contacts)
      target[fragment] = std::max_element (counts.begin (), counts.end (), [] (const auto& a, const auto& b) {
                           return a.second < b.second || (a.second == b.second && a.first > b.first);
                         })->first;
  }
  // A fragment still being seen that touches no confirmed object (the first frames of a
  // run, a surface just come into view on its own) shows as itself until it is confirmed.
  for (const auto& [object, keep] : kept)
    if (!keep && recent[object] && !target.count (object))
      target[object] = object;
  std::vector<std::uint32_t> shown (next_label_, 0);
  for (const auto& [label, record] : records_)
  {
    const auto it = target.find (resolve (label));
    shown[label] = it == target.end () ? 0 : it->second;
  }
  uniteBySummedEvidence (shown);
  // One flat surface parted in every view shows as one object (coplanar_surfaces.h).
  std::set<std::uint32_t> stuff;
  for (const auto& [label, record] : records_)
    if (shown[label] != 0)
      stuff.insert (shown[label]);
  for (const auto& [label, record] : records_)  // the objects' own labels (not fragments settled into them)
  {
    const auto it = target.find (resolve (label));
    if (shown[label] != 0 && it != target.end () && it->second == resolve (label) && !record.bestClass ().empty ())
      stuff.erase (shown[label]);
  }
  // Pairs of objects the evidence has had its say on: votes on their labels' pairs, for
  // or against, in confirm_confidence frames or more (the frames it needs to decide).
  std::set<std::pair<std::uint32_t, std::uint32_t>> judged;
  for (const auto& [pair, counts] : votesByObject (evidence_, shown))
    if (counts.together + counts.apart >= config.confirm_confidence)
      judged.insert (pair);
  const auto joined = detail::coplanarSurfaces (volume, labels, shown, stuff, judged, config);
  std::unordered_map<std::uint32_t, std::uint32_t> out;
  for (const auto& [label, record] : records_)
    if (shown[label] != 0)
    {
      const auto it = joined.find (shown[label]);
      out[label] = it == joined.end () ? shown[label] : it->second;
    }
  return out;
}

void
GlobalSegmentMap::uniteBySummedEvidence (std::vector<std::uint32_t>& shown) const
{
  // A surface the views see at a grazing angle (the side of a refrigerator, the front
  // of a cabinet beside it) keeps few voxels per frame, and propagation gives it a fresh
  // label in most frames: the frames' votes then spread over many label pairs, none
  // reaching confirm_confidence, and pieces that every frame saw together stay apart
  // (a generated kitchen: 84 votes together and none apart between a refrigerator's
  // front and the strip of its side, over a dozen label pairs). Summed over the objects'
  // labels' pairs, the same rule (PairEvidence::united) decides, as below.
  const auto sums = votesByObject (evidence_, shown);  // (smaller, larger) object → votes
  const int decide = evidence_.getConfig ().confirm_confidence;
  const auto judgedApart = [&] (std::uint32_t x, std::uint32_t y) {
    const auto it = sums.find ({std::min (x, y), std::max (x, y)});
    return it != sums.end () && it->second.together + it->second.apart >= decide && !evidence_.united (it->second);
  };
  // A pair joins where the summed votes unite it, its votes apart are fewer than the
  // evidence needs to decide (confirm_confidence) and the masks gave both the same class
  // or none. Summed over many labels, a frame can count more than once: a pair seen
  // apart that often (two boxes side by side on a shelf that the network masks as one
  // in some frames) stays the per-label rule's to decide. And frames whose geometry
  // sees no edge between two objects vote them together whatever the masks say of
  // either: books flush with the front of a shelf, a shelf's plinth on the floor (a
  // generated office lost 0.02 object IoU to such joins before the class condition).
  // Most votes together first; a group never holds a pair judged apart, even through a
  // third.
  std::vector<std::pair<std::pair<std::uint32_t, std::uint32_t>, int>> united;
  std::unordered_map<std::uint32_t, SegmentRecord> records;  // the candidates' objects → their labels' records combined
  for (const auto& [pair, counts] : sums)
    if (evidence_.united (counts) && counts.apart < decide)
    {
      united.emplace_back (pair, counts.together);
      records.emplace (pair.first, SegmentRecord ());
      records.emplace (pair.second, SegmentRecord ());
    }
  // Each candidate's class as outputs show it (fragments settled into it included;
  // bestClass reads only the combined class votes and frames seen).
  for (const auto& [label, record] : records_)
  {
    const auto it = records.find (label < shown.size () ? shown[label] : 0);
    if (it != records.end ())
      combine (it->second, record);
  }
  std::unordered_map<std::uint32_t, std::string> classes;
  for (const auto& [object, record] : records)
    classes[object] = record.bestClass ();
  united.erase (std::remove_if (united.begin (), united.end (),
                                [&] (const auto& u) { return classes.at (u.first.first) != classes.at (u.first.second); }),
                united.end ());
  if (united.empty ())
    return;
  std::stable_sort (united.begin (), united.end (), [] (const auto& a, const auto& b) { return a.second > b.second; });
  std::map<std::uint32_t, std::vector<std::uint32_t>> members;  // group (smallest object) → its objects
  std::map<std::uint32_t, std::uint32_t> group;                 // object → its group
  const auto groupOf = [&] (std::uint32_t o) {
    const auto it = group.find (o);
    if (it != group.end ())
      return it->second;
    group[o] = o;
    members[o] = {o};
    return o;
  };
  for (const auto& [pair, together] : united)
  {
    const std::uint32_t ga = groupOf (pair.first), gb = groupOf (pair.second);
    if (ga == gb)
      continue;
    bool apart = false;
    for (const std::uint32_t x : members[ga])
      for (const std::uint32_t y : members[gb])
        apart = apart || judgedApart (x, y);
    if (apart)
      continue;
    const std::uint32_t keep = std::min (ga, gb), gone = std::max (ga, gb);
    for (const std::uint32_t o : members[gone])
      group[o] = keep;
    members[keep].insert (members[keep].end (), members[gone].begin (), members[gone].end ());
    members.erase (gone);
  }
  for (std::uint32_t& object : shown)
  {
    const auto it = group.find (object);
    if (object != 0 && it != group.end ())
      object = it->second;
  }
}

std::optional<SegmentRecord>
GlobalSegmentMap::record (std::uint32_t label) const
{
  if (records_.find (label) == records_.end ())
    return std::nullopt;
  const std::uint32_t root = resolve (label);
  std::optional<SegmentRecord> out;
  for (const auto& [l, r] : records_)
    if (resolve (l) == root)
    {
      if (!out)
      {
        out = r;
        out->id = root;
      }
      else
        combine (*out, r);
    }
  return out;
}
}  // namespace segmentation
}  // namespace cuefusion
