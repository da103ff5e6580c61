#include <cuefusion/common/exceptions.h>
#include <cuefusion/reconstruction/tsdf_volume.h>
#include <cuefusion/segmentation/global_segment_map.h>

#include <algorithm>

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
  const std::uint32_t ra = find (a), rb = find (b);
  if (ra == rb || ra == 0 || rb == 0)
    return ra;
  const std::size_t needed = static_cast<std::size_t> (std::max (ra, rb)) + 1;
  for (std::size_t i = parent_.size (); i < needed; ++i)
    parent_.push_back (static_cast<std::uint32_t> (i));
  parent_[rb] = ra;
  return ra;
}

void
SegmentMergingConfig::validate () const
{
  if (!(candidate_overlap >= 0.f && candidate_overlap < 1.f))
    throw ParameterError ("--merge-overlap", "must lie in [0, 1)");
  if (confirm_confidence < 1 || confirm_confidence > 1000)
    throw ParameterError ("--merge-confidence", "must lie in [1, 1000]");
}

MergeConfidence::MergeConfidence (const SegmentMergingConfig& config) : config_ (config) { config_.validate (); }

std::vector<std::pair<std::uint32_t, std::uint32_t>>
MergeConfidence::update (std::vector<std::pair<std::uint32_t, std::uint32_t>> seen)
{
  for (auto& p : seen)
    if (p.first > p.second)
      std::swap (p.first, p.second);
  std::sort (seen.begin (), seen.end ());
  seen.erase (std::unique (seen.begin (), seen.end ()), seen.end ());
  // −1 for every tracked pair not seen this frame, forgotten at 0.
  for (auto it = confidence_.begin (); it != confidence_.end ();)
    if (!std::binary_search (seen.begin (), seen.end (), it->first) && --it->second <= 0)
      it = confidence_.erase (it);
    else
      ++it;
  std::vector<std::pair<std::uint32_t, std::uint32_t>> confirmed;
  for (const auto& p : seen)
    if (p.first != p.second && p.first != 0 && ++confidence_[p] >= config_.confirm_confidence)
    {
      confirmed.push_back (p);
      confidence_.erase (p);
    }
  return confirmed;
}

int
MergeConfidence::confidence (std::uint32_t a, std::uint32_t b) const
{
  const auto it = confidence_.find ({std::min (a, b), std::max (a, b)});
  return it == confidence_.end () ? 0 : it->second;
}

void
MergeConfidence::resolve (const LabelEquivalence& equivalence)
{
  std::map<std::pair<std::uint32_t, std::uint32_t>, int> resolved;
  for (const auto& [pair, value] : confidence_)
  {
    std::uint32_t a = equivalence.find (pair.first), b = equivalence.find (pair.second);
    if (a == b)
      continue;
    if (a > b)
      std::swap (a, b);
    int& slot = resolved[{a, b}];
    slot = std::max (slot, value);
  }
  confidence_.swap (resolved);
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
  return best;
}

float
SegmentRecord::bestScore () const
{
  const auto it = class_votes.find (bestClass ());
  return it == class_votes.end () || it->second.first == 0 ? 0.f : it->second.second / static_cast<float> (it->second.first);
}

GlobalSegmentMap::GlobalSegmentMap (const SegmentMergingConfig& merging) : confidences_ (merging) {}

SegmentRecord&
GlobalSegmentMap::recordOf (std::uint32_t root)
{
  SegmentRecord& record = records_[root];
  record.id = root;
  return record;
}

std::uint32_t
GlobalSegmentMap::newSegment (std::size_t frame)
{
  const std::uint32_t label = next_label_++;
  SegmentRecord& record = recordOf (label);
  record.first_frame = record.last_frame = frame;
  return label;
}

void
GlobalSegmentMap::observe (std::uint32_t label, std::size_t frame, const SegmentInstance* info)
{
  const std::uint32_t root = resolve (label);
  if (root == 0)
    return;
  SegmentRecord& record = recordOf (root);
  record.last_frame = std::max (record.last_frame, frame);
  if (info && info->instance >= 0 && !info->class_name.empty ())
  {
    auto& vote = record.class_votes[info->class_name];
    ++vote.first;
    vote.second += info->score;
  }
}

std::uint32_t
GlobalSegmentMap::merge (std::uint32_t a, std::uint32_t b)
{
  const std::uint32_t ra = resolve (a), rb = resolve (b);
  if (ra == rb || ra == 0 || rb == 0)
    return ra;
  // The older (smaller) label survives, so a segment keeps its first id.
  const std::uint32_t keep = std::min (ra, rb), gone = std::max (ra, rb);
  equivalence_.unite (keep, gone);
  SegmentRecord& target = recordOf (keep);
  const auto it = records_.find (gone);
  if (it != records_.end ())
  {
    const SegmentRecord& source = it->second;
    target.first_frame = std::min (target.first_frame, source.first_frame);
    target.last_frame = std::max (target.last_frame, source.last_frame);
    for (const auto& [name, vote] : source.class_votes)
    {
      auto& v = target.class_votes[name];
      v.first += vote.first;
      v.second += vote.second;
    }
    target.voxels += source.voxels;
    target.bounds.extend (source.bounds);
    records_.erase (it);
  }
  return keep;
}

std::vector<std::pair<std::uint32_t, std::uint32_t>>
GlobalSegmentMap::updateMerges (const std::vector<std::pair<std::uint32_t, std::uint32_t>>& candidates)
{
  std::vector<std::pair<std::uint32_t, std::uint32_t>> resolved;
  for (const auto& [a, b] : candidates)
    resolved.emplace_back (resolve (a), resolve (b));
  const auto confirmed = confidences_.update (resolved);
  for (const auto& [a, b] : confirmed)
    merge (a, b);
  if (!confirmed.empty ())
  {
    equivalence_.compact ();
    confidences_.resolve (equivalence_);
  }
  return confirmed;
}

void
GlobalSegmentMap::refreshStatistics (const reconstruction::TSDFVolume& volume)
{
  for (auto& [label, record] : records_)
  {
    record.voxels = 0;
    record.bounds.setEmpty ();
  }
  const auto& blocks = volume.blocks ();
  for (const auto& block : blocks)
    for (int z = 0; z < reconstruction::kBlockSide; ++z)
      for (int y = 0; y < reconstruction::kBlockSide; ++y)
        for (int x = 0; x < reconstruction::kBlockSide; ++x)
        {
          const reconstruction::TsdfVoxel& voxel =
            block->voxels[static_cast<std::size_t> (reconstruction::localVoxelIndex (x, y, z))];
          if (voxel.weight <= 0.f || voxel.label == 0)
            continue;
          const auto it = records_.find (resolve (voxel.label));
          if (it == records_.end ())
            continue;
          ++it->second.voxels;
          it->second.bounds.extend (volume.voxelPosition (block->index * reconstruction::kBlockSide + Eigen::Vector3i (x, y, z)));
        }
}

std::vector<SegmentRecord>
GlobalSegmentMap::segments () const
{
  std::vector<SegmentRecord> out;
  for (const auto& [label, record] : records_)
    out.push_back (record);
  return out;
}

const SegmentRecord*
GlobalSegmentMap::record (std::uint32_t label) const
{
  const auto it = records_.find (resolve (label));
  return it == records_.end () ? nullptr : &it->second;
}
}  // namespace segmentation
}  // namespace cuefusion
