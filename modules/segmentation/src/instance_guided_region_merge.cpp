// SPDX-License-Identifier: BSD-3-Clause
#include <cuefusion/common/exceptions.h>
#include <cuefusion/segmentation/concavity_edge_estimation.h>
#include <cuefusion/segmentation/edge_operators.h>
#include <cuefusion/segmentation/instance_guided_region_merge.h>

#include "instance_merge_detail.h"
#include "overlap_table.h"

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
void
InstanceGuidedRegionMergeConfig::validate () const
{
  if (!(std::isfinite (min_overlap) && min_overlap >= 0.f && min_overlap < 1.f))
    throw ParameterError ("InstanceGuidedRegionMergeConfig::min_overlap", "must lie in [0, 1)");
  if (!(std::isfinite (split_share) && split_share > 0.f && split_share <= 0.5f))
    throw ParameterError ("InstanceGuidedRegionMergeConfig::split_share", "must lie in (0, 0.5]");
  if (split_min_pixels < 1)
    throw ParameterError ("InstanceGuidedRegionMergeConfig::split_min_pixels", "must be at least 1");
  if (!(std::isfinite (occlusion_split_share) && occlusion_split_share >= 0.f))
    throw ParameterError ("InstanceGuidedRegionMergeConfig::occlusion_split_share", "must be a share >= 0 (above 0.5: never)");
  if (mask_boundary_tolerance < 0 || mask_boundary_tolerance > 16)
    throw ParameterError ("InstanceGuidedRegionMergeConfig::mask_boundary_tolerance", "must lie in [0, 16] pixels (0: off)");
  if (!(std::isfinite (color_split_distance) && color_split_distance >= 0.f))
    throw ParameterError ("InstanceGuidedRegionMergeConfig::color_split_distance", "must be >= 0 (0: off)");
  if (!(std::isfinite (color_split_share) && color_split_share > 0.f && color_split_share <= 0.5f))
    throw ParameterError ("InstanceGuidedRegionMergeConfig::color_split_share", "must lie in (0, 0.5]");
  if (!(std::isfinite (max_depth_jump) && max_depth_jump > 0.f && max_depth_jump < 1.f))
    throw ParameterError ("InstanceGuidedRegionMergeConfig::max_depth_jump", "must lie in (0, 1)");
  if (!(std::isfinite (rim_max_normal_angle_deg) && rim_max_normal_angle_deg >= 0.f && rim_max_normal_angle_deg <= 180.f))
    throw ParameterError ("InstanceGuidedRegionMergeConfig::rim_max_normal_angle_deg", "must lie in [0, 180] degrees");
  if (!(std::isfinite (noise_ratio) && noise_ratio >= 0.f && noise_ratio <= 100.f))
    throw ParameterError ("InstanceGuidedRegionMergeConfig::noise_ratio", "must lie in [0, 100] (1: Kinect-class noise, 0: exact depth)");
}

InstanceGuidedRegionMerge::InstanceGuidedRegionMerge (const InstanceGuidedRegionMergeConfig& config) { setConfig (config); }

void
InstanceGuidedRegionMerge::setConfig (const InstanceGuidedRegionMergeConfig& config)
{
  config.validate ();
  config_ = config;
}

namespace detail
{
/** \brief Per label of \a labels (CV_32S, 1..max): its pixel count and the instance ids
  * of \a ids it meets, with their pixels; with \a color (CV_8UC3) and \a sums, also
  * those pixels' summed colour (BGR), sums[l][e] for entry e of label l. */
OverlapTable<int>
countOverlaps (const cv::Mat& labels, const cv::Mat& ids, const cv::Mat& color, std::vector<std::vector<cv::Vec3d>>* sums)
{
  double max_label = 0.0;
  cv::minMaxLoc (labels, nullptr, &max_label);
  OverlapTable<int> out (static_cast<std::size_t> (std::max (0.0, max_label)) + 1);
  const bool with_color = sums && !color.empty ();
  if (with_color)
    sums->assign (out.labels (), {});
  for (int y = 0; y < labels.rows; ++y)
  {
    const std::int32_t* g = labels.ptr<std::int32_t> (y);
    const std::uint16_t* s = ids.ptr<std::uint16_t> (y);
    const cv::Vec3b* bgr = with_color ? color.ptr<cv::Vec3b> (y) : nullptr;
    for (int x = 0; x < labels.cols; ++x)
    {
      if (g[x] <= 0)
        continue;
      const auto l = static_cast<std::size_t> (g[x]);
      ++out.size[l];
      if (s[x] == 0)
        continue;
      const std::size_t e = out.add (l, s[x], 1);
      if (!with_color)
        continue;
      auto& sum = (*sums)[l];
      if (e == sum.size ())
        sum.emplace_back (0.0, 0.0, 0.0);
      sum[e] += cv::Vec3d (bgr[x][0], bgr[x][1], bgr[x][2]);
    }
  }
  return out;
}

void
checkInputs (const cv::Mat& geometric, const std::vector<Instance>& instances)
{
  if (geometric.type () != CV_32S || geometric.empty ())
    throw Error ("InstanceGuidedRegionMerge", "L^G must be a non-empty CV_32S label image");
  for (const Instance& instance : instances)
    if (instance.mask.size () != geometric.size () || instance.mask.type () != CV_8U)
      throw Error ("InstanceGuidedRegionMerge", "instance mask is not CV_8U of L^G's size " +
                                                  std::to_string (geometric.cols) + "x" + std::to_string (geometric.rows));
}

SegmentInstance
describe (const std::vector<Instance>& instances, int id)
{
  SegmentInstance info;
  if (id > 0)
  {
    const Instance& source = instances[static_cast<std::size_t> (id - 1)];
    info.instance = id - 1;
    info.class_id = source.class_id;
    info.class_name = source.class_name;
    info.score = source.score;
  }
  return info;
}
}  // namespace detail

using namespace detail;


void
InstanceGuidedRegionMerge::split (const cv::Mat& geometric, const std::vector<Instance>& given, cv::Mat& pieces,
                                  std::vector<SegmentInstance>* segments, const SurfacePlanes* planes, const cv::Mat& color) const
{
  splitAlongMasks (geometric, given, pieces, segments, planes, color);
}

namespace
{
/** Whether at depth \a z the normals' noise exceeds the concavity test's own threshold:
  * ConcavityEdgeEstimationConfig's noise_slope · σ_z(z) / z > acos threshold, σ_z the
  * Kinect model's times \a noise_ratio (beyond about 1.25 m at ratio 1). There Φ's
  * threshold gives way to the noise, the edge band at an object's base widens and its
  * pixels lose their normals, and the rim's normal test applies
  * (rim_max_normal_angle_deg). Nearer, or on exact depth, the band is narrow and the
  * normals turn fast only along an object's own rim, which the masks should complete:
  * with the test there, osd-learn's boundary F fell 0.3, ycb-real's 0.7, and an object
  * of a noise-free tabletop map lost 0.1 IoU. */
bool
normalsAreNoisyAt (float z, float noise_ratio)
{
  static const ConcavityEdgeEstimationConfig concavity;
  static const float floor_angle = std::acos (concavity.threshold);
  return normalNoiseAngle (z, concavity.noise_slope * noise_ratio) > floor_angle;
}


/** \brief splitAlongMasks(): 0-pixels of \a pieces with a point join the piece their
  * instance claims when inside that mask and connected to it on one surface (see split()). */
void
completeRims (const InstanceGuidedRegionMergeConfig& config, const SurfacePlanes& planes, const cv::Mat& ids,
              const std::vector<SegmentInstance>& info, cv::Mat& pieces)
{
  // The rim: 0-pixels with a point inside the mask of the instance claiming a piece
  // they continue in depth and in surface orientation (rim_max_normal_angle_deg).
  auto* out = pieces.ptr<std::int32_t> ();
  const auto* id = ids.ptr<std::uint16_t> ();
  const float* z = planes.z.data ();
  const float* nx = planes.nx.data ();
  const float* ny = planes.ny.data ();
  const float* nz = planes.nz.data ();
  // Planes given with points only (assignPoints) have no normals: the rim then follows depth alone.
  const bool check_normals = config.rim_max_normal_angle_deg < 180.f && config.noise_ratio > 0.f &&
                             std::any_of (planes.nz.begin (), planes.nz.end (), [] (float v) { return std::isfinite (v) && v != 0.f; });
  const float min_cos = std::cos (config.rim_max_normal_angle_deg * static_cast<float> (M_PI) / 180.f);
  const int rows = pieces.rows, cols = pieces.cols, total = rows * cols;
  std::vector<int> queue;
  for (int i = 0; i < total; ++i)
    if (out[i] > 0 && info[static_cast<std::size_t> (out[i])].instance >= 0)
      queue.push_back (i);
  growFourConnected (queue, rows, cols, [&] (int i, int j) {
    const int claimed = info[static_cast<std::size_t> (out[i])].instance + 1;
    if (out[j] != 0 || id[j] != claimed || !std::isfinite (z[j]) ||
        !(std::abs (z[j] - z[i]) <= config.max_depth_jump * std::min (z[i], z[j])))
      return false;
    if (!check_normals || !normalsAreNoisyAt (z[j], config.noise_ratio))
    {
      out[j] = out[i];
      return true;
    }
    const float turn = nx[i] * nx[j] + ny[i] * ny[j] + nz[i] * nz[j];
    if (turn < min_cos)
      return false;  // a turn beyond the angle
    out[j] = out[i];
    return std::isfinite (turn);  // a pixel without a normal ends the rim there
  });
}


/** \brief splitAlongMasks(): pieces the masks cover only in part are claimed when more
  * than min_overlap of them lies inside their best instance's mask or within
  * mask_boundary_tolerance pixels of it (a mask's boundary is that uncertain).
  */
void
claimWithinBoundaryTolerance (const InstanceGuidedRegionMergeConfig& config, const cv::Mat& pieces, const cv::Mat& ids,
                              const OverlapTable<int>& covered, const std::vector<Instance>& instances,
                              std::vector<SegmentInstance>& info)
{
  const int t = config.mask_boundary_tolerance;
  if (t <= 0)
    return;
  std::vector<int> candidate (info.size (), 0);  // per piece: the instance id to test, 0 = none
  bool any = false;
  for (std::size_t l = 1; l < covered.labels () && l < info.size (); ++l)
    if (info[l].instance < 0 && info[l].coverage >= 1.f - config.min_overlap && covered.size[l] > 0)
    {
      candidate[l] = covered.best (l).first;
      any = any || candidate[l] != 0;
    }
  if (!any)
    return;
  std::vector<int> near (info.size (), 0);
  const int rows = pieces.rows, cols = pieces.cols;
  for (int y = 0; y < rows; ++y)
  {
    const std::int32_t* p = pieces.ptr<std::int32_t> (y);
    const std::uint16_t* s = ids.ptr<std::uint16_t> (y);
    for (int x = 0; x < cols; ++x)
    {
      const int l = p[x];
      if (l <= 0 || candidate[static_cast<std::size_t> (l)] == 0)
        continue;
      const int id = candidate[static_cast<std::size_t> (l)];
      bool found = s[x] == id;
      for (int v = std::max (0, y - t); v <= std::min (rows - 1, y + t) && !found; ++v)
      {
        const std::uint16_t* row = ids.ptr<std::uint16_t> (v);
        for (int u = std::max (0, x - t); u <= std::min (cols - 1, x + t) && !found; ++u)
          found = row[u] == id;
      }
      near[static_cast<std::size_t> (l)] += found ? 1 : 0;
    }
  }
  for (std::size_t l = 1; l < info.size (); ++l)
    if (candidate[l] != 0 && static_cast<float> (near[l]) > config.min_overlap * static_cast<float> (covered.size[l]))
    {
      const float coverage = info[l].coverage;
      info[l] = describe (instances, candidate[l]);
      info[l].coverage = coverage;
      info[l].geometric_segments = 1;
    }
}
}  // namespace

std::vector<Instance>
InstanceGuidedRegionMerge::splitAlongMasks (const cv::Mat& geometric_given, const std::vector<Instance>& given, cv::Mat& pieces,
                                            std::vector<SegmentInstance>* segments, const SurfacePlanes* planes,
                                            const cv::Mat& color) const
{
  checkInputs (geometric_given, given);
  if (planes && (planes->width != geometric_given.cols || planes->height != geometric_given.rows))
    throw Error ("InstanceGuidedRegionMerge", "the surface planes must be of L^G's size");
  // One id image and one count serve the colour division and the cut, unless masks were
  // divided (then the divided ones are counted again).
  const bool by_color = colorDivisionApplies (config_, geometric_given, given, color);
  cv::Mat ids = instancesToIdImage (given, geometric_given.size ());  // id = index + 1, higher score on top
  // With the colour, claimed segments of two colours side by side are divided first.
  cv::Mat geometric = geometric_given;
  std::vector<std::vector<cv::Vec3d>> sums;
  OverlapTable<int> overlaps = by_color ? countDividingByColor (config_, geometric, ids, color, sums) : countOverlaps (geometric, ids);
  std::vector<Instance> instances = by_color ? divideOwned (config_, geometric, given, ids, overlaps, sums) : given;
  if (instances.size () != given.size ())
  {
    ids = instancesToIdImage (instances, geometric.size ());
    overlaps = countOverlaps (geometric, ids);
  }
  const std::size_t labels = overlaps.labels ();

  // The instances that each hold a substantial part of a segment; two or more cut it.
  std::vector<std::vector<std::pair<int, int>>> parts (labels);
  bool any_split = false;
  for (std::size_t g = 1; g < labels; ++g)
  {
    const float needed = std::max (static_cast<float> (config_.split_min_pixels), config_.split_share * static_cast<float> (overlaps.size[g]));
    for (const auto& [id, count] : overlaps.overlap[g])
      if (static_cast<float> (count) >= needed)
        parts[g].emplace_back (id, count);
    if (parts[g].size () < 2)
      parts[g].clear ();
    any_split = any_split || !parts[g].empty ();
  }

  // part: the instance id whose piece a pixel of a cut segment joins (0: segment whole).
  const int cols = geometric.cols;
  cv::Mat part (geometric.size (), CV_32S, cv::Scalar (0));
  if (any_split)
  {
    std::vector<int> queue;
    for (int y = 0; y < geometric.rows; ++y)
    {
      const std::int32_t* g = geometric.ptr<std::int32_t> (y);
      const std::uint16_t* s = ids.ptr<std::uint16_t> (y);
      std::int32_t* p = part.ptr<std::int32_t> (y);
      for (int x = 0; x < cols; ++x)
      {
        if (g[x] <= 0 || parts[static_cast<std::size_t> (g[x])].empty ())
          continue;
        const auto& list = parts[static_cast<std::size_t> (g[x])];
        const bool owned = s[x] && std::any_of (list.begin (), list.end (), [&] (const std::pair<int, int>& e) { return e.first == s[x]; });
        p[x] = owned ? s[x] : -1;
        if (owned)
          queue.push_back (y * cols + x);
      }
    }
    // Pixels of a cut segment that no qualifying mask holds join the nearest piece
    // (breadth-first, 4-connected, inside the segment); any left unreached join the
    // largest piece.
    auto* p = part.ptr<std::int32_t> ();
    const auto* g = geometric.ptr<std::int32_t> ();
    growFourConnected (queue, geometric.rows, cols, [&] (int i, int j) {
      if (p[j] != -1 || g[j] != g[i])
        return false;
      p[j] = p[i];
      return true;
    });
    const int total = geometric.rows * cols;
    for (int i = 0; i < total; ++i)
      if (p[i] == -1)
      {
        const auto& list = parts[static_cast<std::size_t> (g[i])];
        p[i] = std::max_element (list.begin (), list.end (), [] (const auto& a, const auto& b) { return a.second < b.second; })->first;
      }
  }

  // Pieces numbered in raster order of their first pixel: per segment, its (part, piece
  // number) pairs, a handful at most (a map keyed by the pair cost a node per pixel).
  pieces.create (geometric.size (), CV_32S);
  std::vector<std::vector<std::pair<int, std::int32_t>>> numbering (labels);
  std::int32_t numbered = 0;
  for (int y = 0; y < geometric.rows; ++y)
  {
    const std::int32_t* g = geometric.ptr<std::int32_t> (y);
    const std::int32_t* p = part.ptr<std::int32_t> (y);
    std::int32_t* out = pieces.ptr<std::int32_t> (y);
    for (int x = 0; x < cols; ++x)
    {
      if (g[x] <= 0)
      {
        out[x] = 0;
        continue;
      }
      const auto segment = static_cast<std::size_t> (g[x]);
      if (segment >= numbering.size ())
        numbering.resize (segment + 1);
      auto& list = numbering[segment];
      const auto it = std::find_if (list.begin (), list.end (), [&] (const auto& e) { return e.first == p[x]; });
      if (it != list.end ())
        out[x] = it->second;
      else
      {
        list.emplace_back (p[x], ++numbered);
        out[x] = numbered;
      }
    }
  }
  if (!segments && !planes)
    return instances;
  const OverlapTable<int> covered = countOverlaps (pieces, ids);
  std::vector<SegmentInstance> info (static_cast<std::size_t> (numbered) + 1);
  for (std::size_t l = 1; l < covered.labels (); ++l)
  {
    const auto [id, count] = covered.best (l);
    const float coverage = covered.size[l] > 0 ? static_cast<float> (count) / static_cast<float> (covered.size[l]) : 0.f;
    if (id && coverage > config_.min_overlap)
      info[l] = describe (instances, id);
    info[l].coverage = coverage;
    info[l].geometric_segments = 1;
  }
  claimWithinBoundaryTolerance (config_, pieces, ids, covered, instances, info);
  if (planes)
    completeRims (config_, *planes, ids, info, pieces);
  if (segments)
    segments->swap (info);
  return instances;
}


void
masksAsSegments (const std::vector<Instance>& instances, const SurfacePlanes& planes, cv::Mat& labels,
                 std::vector<SegmentInstance>* segments)
{
  const cv::Size size (planes.width, planes.height);
  instancesToIdImage (instances, size).convertTo (labels, CV_32S);
  for (int y = 0; y < size.height; ++y)
    for (int x = 0; x < size.width; ++x)
      if (!std::isfinite (planes.z[static_cast<std::size_t> (y) * size.width + x]))
        labels.at<std::int32_t> (y, x) = 0;
  if (!segments)
    return;
  segments->assign (1, SegmentInstance ());
  for (std::size_t i = 0; i < instances.size (); ++i)
  {
    SegmentInstance info;
    info.instance = static_cast<int> (i);
    info.class_id = instances[i].class_id;
    info.class_name = instances[i].class_name;
    info.score = instances[i].score;
    segments->push_back (info);
  }
}
}  // namespace segmentation
}  // namespace cuefusion
