// SPDX-License-Identifier: BSD-3-Clause
// InstanceGuidedRegionMerge::merge (§4.2.1.3): the pieces one mask covers grouped into one
// segment unless a crease or a depth gap parts them.
#include <cuefusion/common/exceptions.h>
#include <cuefusion/segmentation/instance_guided_region_merge.h>

#include "disjoint_sets.h"
#include "instance_merge_detail.h"

#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <climits>
#include <cmath>
#include <iterator>
#include <map>
#include <set>
#include <utility>

namespace cuefusion
{
namespace segmentation
{
using namespace detail;

namespace
{
/** \brief For merge(): per piece, the piece standing for its group among the pieces its
  * instance claims. All of an instance's pieces form one group, unless two of them, each
  * holding at least \a share of the instance's pieces, touch mostly along depth jumps
  * (> 2 % of the depth between pixels 1–2 apart, the rule the normals use): then groups
  * are the instance's pieces connected by contacts that are not such jumps.
  */
std::vector<std::size_t>
groupsAlongCreases (const cv::Mat& pieces, const std::vector<SegmentInstance>& info, const SurfacePlanes& planes, float share,
                    float max_depth_jump)
{
  const std::size_t n = info.size ();
  std::vector<int> size (n, 0);
  std::map<std::pair<std::size_t, std::size_t>, std::pair<int, int>> contacts;  // (p, q) → (contacts, jumps)
  const int rows = pieces.rows, cols = pieces.cols;
  for (int y = 0; y < rows; ++y)
  {
    const std::int32_t* row = pieces.ptr<std::int32_t> (y);
    const float* z = planes.z.data () + static_cast<std::size_t> (y) * cols;
    for (int x = 0; x < cols; ++x)
    {
      const auto p = static_cast<std::size_t> (std::max (0, row[x]));
      if (p == 0)
        continue;
      ++size[p];
      if (info[p].instance < 0)
        continue;
      for (const auto& [dx, dy] : {std::pair<int, int> (1, 0), {2, 0}, {0, 1}, {0, 2}})
      {
        if (x + dx >= cols || y + dy >= rows)
          continue;
        const int other = pieces.ptr<std::int32_t> (y + dy)[x + dx];
        const auto q = static_cast<std::size_t> (std::max (0, other));
        if (q == 0 || q == p || info[q].instance != info[p].instance)
          continue;
        const float z0 = z[x], z1 = planes.z[static_cast<std::size_t> (y + dy) * cols + x + dx];
        auto& c = contacts[{std::min (p, q), std::max (p, q)}];
        ++c.first;
        c.second += std::abs (z0 - z1) > max_depth_jump * std::min (z0, z1) ? 1 : 0;
      }
    }
  }
  std::map<int, int> claimed;  // instance → pixels of its pieces
  for (std::size_t l = 1; l < n; ++l)
    if (info[l].instance >= 0)
      claimed[info[l].instance] += size[l];
  // A piece holding at least share of its instance's pieces (p and q of one instance).
  const auto sizeable = [&] (std::size_t l) { return static_cast<float> (size[l]) >= share * static_cast<float> (claimed[info[l].instance]); };
  const auto apart = [&] (std::size_t p, std::size_t q, const std::pair<int, int>& c) {
    return 2 * c.second >= c.first && sizeable (p) && sizeable (q);
  };
  std::set<int> divided;
  for (const auto& [pair, c] : contacts)
    if (apart (pair.first, pair.second, c))
      divided.insert (info[pair.first].instance);
  // Union–find over the pieces: whole instances, or crease-connected parts of divided ones.
  detail::DisjointSets groups (n);
  const auto find = [&groups] (std::size_t l) { return groups.find (l); };
  std::map<int, std::size_t> first_piece;
  for (std::size_t l = 1; l < n; ++l)
    if (info[l].instance >= 0 && !divided.count (info[l].instance))
    {
      const auto it = first_piece.emplace (info[l].instance, l).first;
      groups.join (it->second, l);
    }
  for (const auto& [pair, c] : contacts)
    if (divided.count (info[pair.first].instance) && !apart (pair.first, pair.second, c) && 2 * c.second < c.first)
      groups.join (pair.first, pair.second);
  // Only sizeable pieces are told apart: a part of a divided instance too small to be
  // apart (a key raised on a keyboard, a knob) that no crease joins to a sizeable piece
  // joins the group it touches most among those holding one. Without this every raised
  // key of a keyboard whose body and key field meet along jumps was a segment of its own.
  std::vector<char> holds_sizeable (n, 0);
  for (std::size_t l = 1; l < n; ++l)
    if (info[l].instance >= 0 && sizeable (l))
      holds_sizeable[find (l)] = 1;
  std::map<std::size_t, std::pair<int, std::size_t>> attach;  // small piece's root → (contacts, sizeable group)
  for (const auto& [pair, c] : contacts)
  {
    if (!divided.count (info[pair.first].instance))
      continue;
    for (const auto& [small, other] : {pair, std::make_pair (pair.second, pair.first)})
    {
      const std::size_t from = find (small), to = find (other);
      if (holds_sizeable[from] || !holds_sizeable[to])
        continue;
      auto& best = attach[from];
      if (c.first > best.first || (c.first == best.first && to < best.second))
        best = {c.first, to};
    }
  }
  for (const auto& [from, best] : attach)
    groups.join (best.second, from);
  return groups.roots ();
}
}  // namespace

void
InstanceGuidedRegionMerge::merge (const cv::Mat& geometric, const std::vector<Instance>& given, cv::Mat& fused,
                                  std::vector<SegmentInstance>* segments, const SurfacePlanes* planes, const cv::Mat& color) const
{
  // Cut where the masks see two objects, then unite the pieces each instance covers.
  cv::Mat pieces;
  std::vector<SegmentInstance> piece_info;
  const std::vector<Instance> instances = splitAlongMasks (geometric, given, pieces, &piece_info, planes, color);
  std::vector<std::size_t> group (piece_info.size ());
  if (planes && config_.occlusion_split_share <= 0.5f)
    group = groupsAlongCreases (pieces, piece_info, *planes, config_.occlusion_split_share, config_.max_depth_jump);
  else
    for (std::size_t l = 0; l < group.size (); ++l)
      group[l] = piece_info[l].instance >= 0 ? static_cast<std::size_t> (piece_info[l].instance) + piece_info.size () : l;
  // Output labels in raster order of first pixels; keys: a claimed piece's group, or the
  // piece itself.
  const auto keyOf = [&] (std::size_t piece) -> std::size_t { return piece_info[piece].instance >= 0 ? group[piece] : piece; };
  fused.create (geometric.size (), CV_32S);
  std::map<std::size_t, std::int32_t> output;
  if (segments)
    segments->assign (1, SegmentInstance ());
  for (int y = 0; y < pieces.rows; ++y)
  {
    const std::int32_t* g = pieces.ptr<std::int32_t> (y);
    std::int32_t* out = fused.ptr<std::int32_t> (y);
    for (int x = 0; x < pieces.cols; ++x)
    {
      if (g[x] <= 0)
      {
        out[x] = 0;
        continue;
      }
      const auto piece = static_cast<std::size_t> (g[x]);
      auto it = output.find (keyOf (piece));
      if (it == output.end ())
      {
        it = output.emplace (keyOf (piece), static_cast<std::int32_t> (output.size () + 1)).first;
        if (segments)
        {
          const int instance = piece_info[piece].instance;
          segments->push_back (describe (instances, instance >= 0 ? instance + 1 : 0));
        }
      }
      out[x] = it->second;
    }
  }
  if (!segments)
    return;
  // Per output segment: how many pieces it unites and the share of it its instance covers.
  std::vector<float> pixels (segments->size (), 0.f), under (segments->size (), 0.f), size (piece_info.size (), 0.f);
  for (int y = 0; y < pieces.rows; ++y)
  {
    const std::int32_t* g = pieces.ptr<std::int32_t> (y);
    for (int x = 0; x < pieces.cols; ++x)
      if (g[x] > 0)
        size[static_cast<std::size_t> (g[x])] += 1.f;
  }
  for (std::size_t l = 1; l < piece_info.size (); ++l)
  {
    if (size[l] == 0.f)
      continue;
    const std::size_t target = static_cast<std::size_t> (output.at (keyOf (l)));
    SegmentInstance& info = (*segments)[target];
    ++info.geometric_segments;
    pixels[target] += size[l];
    under[target] += piece_info[l].coverage * size[l];
  }
  for (std::size_t l = 1; l < segments->size (); ++l)
    (*segments)[l].coverage = pixels[l] > 0.f ? under[l] / pixels[l] : 0.f;
}
}  // namespace segmentation
}  // namespace cuefusion
