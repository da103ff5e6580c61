// SPDX-License-Identifier: BSD-3-Clause
#include <cuefusion/common/exceptions.h>
#include <cuefusion/segmentation/instance_guided_region_merge.h>

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
}

InstanceGuidedRegionMerge::InstanceGuidedRegionMerge (const InstanceGuidedRegionMergeConfig& config) { setConfig (config); }

void
InstanceGuidedRegionMerge::setConfig (const InstanceGuidedRegionMergeConfig& config)
{
  config.validate ();
  config_ = config;
}

namespace
{
/** \brief Breadth-first growth over the 4-connected pixels of a \a rows × \a cols image
  * from every index in \a queue: a neighbour j of a reached pixel i is reached when
  * join(i, j) accepts (and marks) it. \a queue ends holding every pixel reached. */
template <typename Join>
void
growFourConnected (std::vector<int>& queue, int rows, int cols, Join&& join)
{
  for (std::size_t k = 0; k < queue.size (); ++k)
  {
    const int i = queue[k], x = i % cols, y = i / cols;
    for (const int j : {x > 0 ? i - 1 : -1, x + 1 < cols ? i + 1 : -1, y > 0 ? i - cols : -1, y + 1 < rows ? i + cols : -1})
      if (j >= 0 && join (i, j))
        queue.push_back (j);
  }
}

/** \brief Per label of \a labels (CV_32S, 1..max): its pixel count and the instance ids
  * of \a ids it meets, with their pixels; with \a color (CV_8UC3) and \a sums, also
  * those pixels' summed colour (BGR), sums[l][e] for entry e of label l. */
OverlapTable<int>
countOverlaps (const cv::Mat& labels, const cv::Mat& ids, const cv::Mat& color = cv::Mat (),
               std::vector<std::vector<cv::Vec3d>>* sums = nullptr)
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
/** Mean colours below this (of 255, over the three channels) give no chromaticity worth
  * comparing: sensor noise dominates a dark surface's hue. */
constexpr double kMinMeanBrightness = 20.0;

/** One segment an instance claims, with the rg chromaticity of its claimed pixels' mean
  * colour (known = bright enough to have one). */
struct ColorClaim
{
  std::size_t segment = 0;
  int pixels = 0;
  bool known = false;
  float r = 0.f, g = 0.f;
};

ColorClaim
colorClaim (std::size_t segment, int pixels, const cv::Vec3d& sum)
{
  ColorClaim claim;
  claim.segment = segment;
  claim.pixels = pixels;
  const double total = sum[0] + sum[1] + sum[2];
  claim.known = total >= 3.0 * kMinMeanBrightness * pixels;
  if (claim.known)
  {
    claim.r = static_cast<float> (sum[2] / total);
    claim.g = static_cast<float> (sum[1] / total);
  }
  return claim;
}

/** The colour groups of one instance's claims: per claim, the index of the claim standing
  * for its group (single linkage under \a distance; unknown colours stay alone). */
std::vector<std::size_t>
colorGroups (const std::vector<ColorClaim>& claims, float distance)
{
  std::vector<std::size_t> group (claims.size ());
  for (std::size_t i = 0; i < claims.size (); ++i)
    group[i] = i;
  const auto find = [&] (std::size_t i) {
    while (group[i] != i)
      i = group[i] = group[group[i]];
    return i;
  };
  for (std::size_t i = 0; i < claims.size (); ++i)
    for (std::size_t j = i + 1; j < claims.size (); ++j)
      if (claims[i].known && claims[j].known &&
          std::hypot (claims[i].r - claims[j].r, claims[i].g - claims[j].g) < distance)
        group[find (j)] = find (i);
  for (std::size_t i = 0; i < claims.size (); ++i)
    group[i] = find (i);
  return group;
}

/** The pixels instance \a k owns (id k + 1 in \a ids) go to the instance of the nearest
  * pixel of a segment it claims (destination by segment, −1 = not claimed): its claimed
  * segments, and the rim and edge band around each, follow their colour group. */
void
moveToNearestGroup (const cv::Mat& geometric, const cv::Mat& ids, int k, const std::vector<int>& destination, std::vector<Instance>& out)
{
  const auto id = static_cast<std::uint16_t> (k + 1);
  const cv::Rect box = cv::boundingRect (out[static_cast<std::size_t> (k)].mask);
  cv::Mat seeds (box.size (), CV_8U, cv::Scalar (255)), distance, nearest;
  for (int y = 0; y < box.height; ++y)
    for (int x = 0; x < box.width; ++x)
    {
      const std::int32_t g = geometric.at<std::int32_t> (box.y + y, box.x + x);
      if (g > 0 && destination[static_cast<std::size_t> (g)] >= 0 && ids.at<std::uint16_t> (box.y + y, box.x + x) == id)
        seeds.at<std::uint8_t> (y, x) = 0;
    }
  cv::distanceTransform (seeds, distance, nearest, cv::DIST_L2, cv::DIST_MASK_3, cv::DIST_LABEL_PIXEL);
  std::vector<int> taker (static_cast<std::size_t> (box.area ()) + 1, k);  // by label of a seed pixel
  for (int y = 0; y < box.height; ++y)
    for (int x = 0; x < box.width; ++x)
      if (seeds.at<std::uint8_t> (y, x) == 0)
        taker[static_cast<std::size_t> (nearest.at<std::int32_t> (y, x))] =
          destination[static_cast<std::size_t> (geometric.at<std::int32_t> (box.y + y, box.x + x))];
  std::set<int> changed;
  for (int y = 0; y < box.height; ++y)
    for (int x = 0; x < box.width; ++x)
    {
      const int t = taker[static_cast<std::size_t> (nearest.at<std::int32_t> (y, x))];
      if (t == k || ids.at<std::uint16_t> (box.y + y, box.x + x) != id)
        continue;
      out[static_cast<std::size_t> (t)].mask.at<std::uint8_t> (box.y + y, box.x + x) = 255;
      out[static_cast<std::size_t> (k)].mask.at<std::uint8_t> (box.y + y, box.x + x) = 0;
      changed.insert (t);
    }
  changed.insert (k);
  for (const int c : changed)
    out[static_cast<std::size_t> (c)].box = cv::boundingRect (out[static_cast<std::size_t> (c)].mask);
}
/** Whether the colour division runs: a colour, the cue on, masks to divide; throws on a
  * colour image of the wrong kind. */
bool
colorDivisionApplies (const InstanceGuidedRegionMergeConfig& config, const cv::Mat& geometric, const std::vector<Instance>& instances,
                      const cv::Mat& color)
{
  if (color.empty () || config.color_split_distance <= 0.f || instances.empty ())
    return false;
  if (color.type () != CV_8UC3 || color.size () != geometric.size ())
    throw Error ("InstanceGuidedRegionMerge", "the colour image must be CV_8UC3 of L^G's size " + std::to_string (geometric.cols) +
                                                "x" + std::to_string (geometric.rows));
  return true;
}


/** Two-means of \a pixels' chromaticity, started deterministically (the pixel farthest from
  * the mean, then the one farthest from it); \a side[i] is pixel i's cluster, \a centre the
  * clusters' centres. */
void
twoMeans (const std::vector<cv::Point2f>& pixels, std::vector<std::uint8_t>& side, cv::Point2f (&centre)[2])
{
  const auto farthest = [&] (cv::Point2f from) {
    cv::Point2f best = from;
    float d_best = -1.f;
    for (const cv::Point2f& c : pixels)
    {
      const cv::Point2f d = c - from;
      if (d.dot (d) > d_best)
      {
        d_best = d.dot (d);
        best = c;
      }
    }
    return best;
  };
  cv::Point2f mean (0.f, 0.f);
  for (const cv::Point2f& c : pixels)
    mean += c;
  mean *= 1.f / static_cast<float> (pixels.size ());
  centre[1] = farthest (mean);
  centre[0] = farthest (centre[1]);
  side.assign (pixels.size (), 0);
  for (int iteration = 0; iteration < 10; ++iteration)
  {
    cv::Point2f sum[2] = {{0.f, 0.f}, {0.f, 0.f}};
    int count[2] = {0, 0};
    for (std::size_t i = 0; i < pixels.size (); ++i)
    {
      const cv::Point2f& p = pixels[i];
      const cv::Point2f d0 = p - centre[0], d1 = p - centre[1];
      side[i] = d1.dot (d1) < d0.dot (d0) ? 1 : 0;
      sum[side[i]] += p;
      ++count[side[i]];
    }
    if (!count[0] || !count[1])
      return;
    const cv::Point2f next[2] = {sum[0] * (1.f / static_cast<float> (count[0])), sum[1] * (1.f / static_cast<float> (count[1]))};
    const bool settled = next[0] == centre[0] && next[1] == centre[1];
    centre[0] = next[0];
    centre[1] = next[1];
    if (settled)
      return;
  }
}

/** Share of a colour part's pixels within color_split_distance / 4 of its mean chromaticity
  * for the part to count as one uniform colour, and share of them its largest connected
  * region (after a 3×3 opening) must hold: a box's face or an object's side, not print,
  * texture or shading. */
constexpr double kUniformShare = 0.8;
constexpr double kCoherentShare = 0.8;
/** Pixels of a segment the colour test looks at, at most (evenly spaced). */
constexpr std::size_t kSample = 2048;

/** Whether any segment a mask claims (more than half of it under one instance's own
  * pixels, by \a owned: countOverlaps of \a geometric and the id image) is made of two
  * uniform, clearly different colours side by side; then \a divided is \a geometric with
  * each such segment divided: two objects of different colours whose faces geometry saw
  * as one plane (two boxes flush, front faces coplanar). The segment's bright-enough
  * pixels (a sample of at most kSample) are split by two-means of their rg chromaticity;
  * it is divided when the two means lie at least color_split_distance apart, each part
  * holds color_split_share of them, at least kUniformShare of each part lies within a
  * quarter of that distance of its mean, and each part is one region (kCoherentShare).
  * The smaller part's region takes a new label; the rest keeps the segment's. Print and
  * texture fail the uniformity test and leave the segment whole; shading does not count
  * (rg chromaticity ignores it). */
bool
divideSegmentsByColor (const InstanceGuidedRegionMergeConfig& config, const cv::Mat& geometric, const cv::Mat& color,
                       const OverlapTable<int>& owned, cv::Mat& divided)
{
  // The colour statistics look at most kSample pixels of a segment, evenly spaced in
  // raster order: a segment of one colour (nearly all of them) costs one pass over them.
  std::vector<std::size_t> stride (owned.labels (), 0), seen (owned.labels (), 0);  // stride 0: not claimed
  for (std::size_t l = 1; l < owned.labels (); ++l)
    if (owned.size[l] >= 2 * config.split_min_pixels && 2 * owned.best (l).second > owned.size[l])
      stride[l] = (static_cast<std::size_t> (owned.size[l]) + kSample - 1) / kSample;
  std::vector<std::vector<cv::Point2f>> sample (owned.labels ());
  std::vector<cv::Vec4i> bounds (owned.labels (), cv::Vec4i (INT_MAX, INT_MAX, -1, -1));  // x0, y0, x1, y1
  const auto chroma = [] (const cv::Vec3b& bgr, cv::Point2f& rg) {
    const float total = static_cast<float> (bgr[0]) + bgr[1] + bgr[2];
    if (total < 3.f * static_cast<float> (kMinMeanBrightness))
      return false;
    rg = cv::Point2f (bgr[2] / total, bgr[1] / total);
    return true;
  };
  for (int y = 0; y < geometric.rows; ++y)
  {
    const std::int32_t* g = geometric.ptr<std::int32_t> (y);
    const cv::Vec3b* bgr = color.ptr<cv::Vec3b> (y);
    for (int x = 0; x < geometric.cols; ++x)
    {
      if (g[x] <= 0 || !stride[static_cast<std::size_t> (g[x])])
        continue;
      const auto l = static_cast<std::size_t> (g[x]);
      cv::Vec4i& b = bounds[l];
      b = cv::Vec4i (std::min (b[0], x), std::min (b[1], y), std::max (b[2], x), std::max (b[3], y));
      cv::Point2f rg;
      if (seen[l]++ % stride[l] == 0 && chroma (bgr[x], rg))
        sample[l].push_back (rg);
    }
  }
  bool any = false;
  double max_label = 0.0;
  cv::minMaxLoc (geometric, nullptr, &max_label);
  auto next = static_cast<std::int32_t> (max_label);
  const float distance = config.color_split_distance, radius = distance / 4.f;
  for (std::size_t l = 1; l < sample.size (); ++l)
  {
    const std::vector<cv::Point2f>& list = sample[l];
    if (!stride[l] || static_cast<int> (list.size () * stride[l]) < 2 * config.split_min_pixels)
      continue;
    std::vector<std::uint8_t> side;
    cv::Point2f centre[2];
    twoMeans (list, side, centre);
    const cv::Point2f gap = centre[0] - centre[1];
    if (std::sqrt (gap.dot (gap)) < distance)
      continue;
    int count[2] = {0, 0}, near[2] = {0, 0};
    for (std::size_t i = 0; i < list.size (); ++i)
    {
      const cv::Point2f d = list[i] - centre[side[i]];
      ++count[side[i]];
      near[side[i]] += d.dot (d) <= radius * radius ? 1 : 0;
    }
    bool divide = true;
    for (int k = 0; k < 2; ++k)
      divide = divide && count[k] >= config.color_split_share * static_cast<double> (list.size ()) &&
               near[k] >= kUniformShare * count[k];
    if (!divide)
      continue;
    // Every bright pixel of the segment to its nearer mean; each part must be one region:
    // the largest 4-connected component of its opened pixels.
    const cv::Vec4i& b = bounds[l];
    const cv::Rect box (b[0], b[1], b[2] - b[0] + 1, b[3] - b[1] + 1);
    cv::Mat part[2] = {cv::Mat (box.size (), CV_8U, cv::Scalar (0)), cv::Mat (box.size (), CV_8U, cv::Scalar (0))};
    int pixels[2] = {0, 0};
    for (int y = 0; y < box.height; ++y)
      for (int x = 0; x < box.width; ++x)
      {
        cv::Point2f rg;
        if (geometric.at<std::int32_t> (box.y + y, box.x + x) != static_cast<std::int32_t> (l) ||
            !chroma (color.at<cv::Vec3b> (box.y + y, box.x + x), rg))
          continue;
        const cv::Point2f d0 = rg - centre[0], d1 = rg - centre[1];
        const int k = d1.dot (d1) < d0.dot (d0) ? 1 : 0;
        part[k].at<std::uint8_t> (y, x) = 1;
        ++pixels[k];
      }
    cv::Mat region[2];
    for (int k = 0; k < 2 && divide; ++k)
    {
      cv::Mat labels, stats, centroids;
      cv::morphologyEx (part[k], part[k], cv::MORPH_OPEN, cv::Mat::ones (3, 3, CV_8U));
      const int found = cv::connectedComponentsWithStats (part[k], labels, stats, centroids, 4, CV_32S);
      int largest = 0;
      for (int c = 1; c < found; ++c)
        if (!largest || stats.at<int> (c, cv::CC_STAT_AREA) > stats.at<int> (largest, cv::CC_STAT_AREA))
          largest = c;
      divide = largest && stats.at<int> (largest, cv::CC_STAT_AREA) >= kCoherentShare * pixels[k];
      if (divide)
        region[k] = labels == largest;
    }
    if (!divide)
      continue;
    if (!any)
      divided = geometric.clone ();
    any = true;
    divided (box).setTo (cv::Scalar (++next), region[pixels[1] < pixels[0] ? 1 : 0]);
  }
  return any;
}

/** countOverlaps of \a geometric against \a ids with the colour; where a claimed segment is
  * two colours side by side (divideSegmentsByColor), \a geometric becomes the divided label
  * image, counted again. */
OverlapTable<int>
countDividingByColor (const InstanceGuidedRegionMergeConfig& config, cv::Mat& geometric, const cv::Mat& ids, const cv::Mat& color,
                      std::vector<std::vector<cv::Vec3d>>& sums)
{
  OverlapTable<int> owned = countOverlaps (geometric, ids, color, &sums);
  cv::Mat divided;
  if (!divideSegmentsByColor (config, geometric, color, owned, divided))
    return owned;
  geometric = divided;
  return countOverlaps (geometric, ids, color, &sums);
}

/** divideByColor on counts already made: \a owned and \a sums from countOverlaps of L^G
  * against \a ids (the instances' id image) with the colour. */
std::vector<Instance>
divideOwned (const InstanceGuidedRegionMergeConfig& config, const cv::Mat& geometric, const std::vector<Instance>& instances,
             const cv::Mat& ids, const OverlapTable<int>& owned, const std::vector<std::vector<cv::Vec3d>>& sums)
{
  // The segments each instance claims (more than half of the segment is its own).
  std::vector<std::vector<ColorClaim>> claims (instances.size ());
  for (std::size_t l = 1; l < owned.labels (); ++l)
    for (std::size_t e = 0; e < owned.overlap[l].size (); ++e)
    {
      const auto [id, pixels] = owned.overlap[l][e];
      if (2 * pixels > owned.size[l])
        claims[static_cast<std::size_t> (id - 1)].push_back (colorClaim (l, pixels, sums[l][e]));
    }

  // Per divided instance, the groups other than its largest become new instances;
  // destination[l] is the instance that takes claimed segment l (−1: not claimed).
  std::vector<Instance> out = instances;
  std::vector<int> destination (owned.labels (), -1);
  std::vector<std::size_t> divided;
  for (std::size_t k = 0; k < instances.size (); ++k)
  {
    const std::vector<ColorClaim>& list = claims[k];
    const std::vector<std::size_t> group = colorGroups (list, config.color_split_distance);
    std::map<std::size_t, int> weight;  // group (its first claim) → pixels
    int total = 0;
    for (std::size_t i = 0; i < list.size (); ++i)
    {
      weight[group[i]] += list[i].pixels;
      total += list[i].pixels;
    }
    std::vector<std::size_t> large;  // colour groups holding color_split_share, first claim order
    for (const auto& [first, pixels] : weight)
      if (list[first].known && static_cast<float> (pixels) >= config.color_split_share * static_cast<float> (total))
        large.push_back (first);
    if (large.size () < 2)
      continue;
    const std::size_t keeper = *std::max_element (large.begin (), large.end (), [&] (std::size_t a, std::size_t b) {
      return weight[a] < weight[b];
    });
    std::map<std::size_t, int> index;  // group → instance taking it
    for (const std::size_t first : large)
      if (first != keeper)
      {
        index[first] = static_cast<int> (out.size ());
        Instance part = instances[k];
        // A new buffer: assigning cv::Mat::zeros would write into the caller's mask it shares.
        part.mask = cv::Mat (instances[k].mask.size (), CV_8U, cv::Scalar (0));
        out.push_back (part);
      }
    for (std::size_t i = 0; i < list.size (); ++i)
    {
      const auto it = index.find (group[i]);
      destination[list[i].segment] = it == index.end () ? static_cast<int> (k) : it->second;
    }
    out[k].mask = instances[k].mask.clone ();
    divided.push_back (k);
  }
  for (const std::size_t k : divided)
    moveToNearestGroup (geometric, ids, static_cast<int> (k), destination, out);
  return out;
}

}  // namespace

void
InstanceGuidedRegionMerge::split (const cv::Mat& geometric, const std::vector<Instance>& given, cv::Mat& pieces,
                                  std::vector<SegmentInstance>* segments, const SurfacePlanes* planes, const cv::Mat& color) const
{
  splitAlongMasks (geometric, given, pieces, segments, planes, color);
}

namespace
{
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

  // Pieces numbered in raster order of their first pixel.
  pieces.create (geometric.size (), CV_32S);
  std::map<std::pair<int, int>, std::int32_t> numbering;
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
      out[x] = numbering.emplace (std::make_pair (g[x], p[x]), static_cast<std::int32_t> (numbering.size () + 1)).first->second;
    }
  }
  if (!segments && !planes)
    return instances;
  const OverlapTable<int> covered = countOverlaps (pieces, ids);
  std::vector<SegmentInstance> info (numbering.size () + 1);
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
  {
    // The rim: 0-pixels with a point inside the mask of the instance claiming a piece
    // they continue in depth.
    auto* out = pieces.ptr<std::int32_t> ();
    const auto* id = ids.ptr<std::uint16_t> ();
    const float* z = planes->z.data ();
    const int rows = geometric.rows, total = rows * cols;
    std::vector<int> queue;
    for (int i = 0; i < total; ++i)
      if (out[i] > 0 && info[static_cast<std::size_t> (out[i])].instance >= 0)
        queue.push_back (i);
    growFourConnected (queue, rows, cols, [&] (int i, int j) {
      const int claimed = info[static_cast<std::size_t> (out[i])].instance + 1;
      if (out[j] != 0 || id[j] != claimed || !std::isfinite (z[j]) ||
          !(std::abs (z[j] - z[i]) <= config_.max_depth_jump * std::min (z[i], z[j])))
        return false;
      out[j] = out[i];
      return true;
    });
  }
  if (segments)
    segments->swap (info);
  return instances;
}

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
  std::vector<std::size_t> group (n);
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
  for (std::size_t l = 0; l < n; ++l)
    group[l] = l;
  const auto find = [&] (std::size_t l) {
    while (group[l] != l)
      l = group[l] = group[group[l]];
    return l;
  };
  std::map<int, std::size_t> first_piece;
  for (std::size_t l = 1; l < n; ++l)
    if (info[l].instance >= 0 && !divided.count (info[l].instance))
    {
      const auto it = first_piece.emplace (info[l].instance, l).first;
      group[find (l)] = find (it->second);
    }
  for (const auto& [pair, c] : contacts)
    if (divided.count (info[pair.first].instance) && !apart (pair.first, pair.second, c) && 2 * c.second < c.first)
      group[find (pair.second)] = find (pair.first);
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
    group[from] = best.second;
  for (std::size_t l = 0; l < n; ++l)
    group[l] = find (l);
  return group;
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

std::vector<Instance>
InstanceGuidedRegionMerge::divideByColor (const cv::Mat& geometric, const std::vector<Instance>& instances, const cv::Mat& color) const
{
  checkInputs (geometric, instances);
  if (!colorDivisionApplies (config_, geometric, instances, color))
    return instances;
  const cv::Mat ids = instancesToIdImage (instances, geometric.size ());  // id = index + 1, higher score on top
  cv::Mat divided = geometric;
  std::vector<std::vector<cv::Vec3d>> sums;
  const OverlapTable<int> owned = countDividingByColor (config_, divided, ids, color, sums);
  return divideOwned (config_, divided, instances, ids, owned, sums);
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
