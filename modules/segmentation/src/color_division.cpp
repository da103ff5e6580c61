// SPDX-License-Identifier: BSD-3-Clause
// InstanceGuidedRegionMerge's colour division (§4.2.1.3 with the colour cue): segments of
// two flat colours side by side divided, masks over clearly different hues cut.
#include <cuefusion/common/exceptions.h>
#include <cuefusion/segmentation/instance_guided_region_merge.h>

#include "instance_merge_detail.h"

#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <climits>
#include <cmath>
#include <iterator>
#include <limits>
#include <map>
#include <numeric>
#include <set>
#include <utility>

namespace cuefusion
{
namespace segmentation
{
namespace detail
{
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

/** The colour groups of one instance's claims: per claim, the index of the first claim of
  * its group. Groups are joined closest first while every colour of the one lies within
  * \a distance of every colour of the other (complete linkage; unknown colours stay alone):
  * no chain of near colours links the first book of a shelf to the last. */
std::vector<std::size_t>
colorGroups (const std::vector<ColorClaim>& claims, float distance)
{
  const std::size_t n = claims.size ();
  std::vector<std::size_t> group (n);
  std::iota (group.begin (), group.end (), 0);
  // far(a, b): the largest distance between a colour of group a and one of group b.
  std::vector<float> far (n * n, std::numeric_limits<float>::infinity ());
  for (std::size_t i = 0; i < n; ++i)
    for (std::size_t j = i + 1; j < n; ++j)
      if (claims[i].known && claims[j].known)
        far[i * n + j] = far[j * n + i] = std::hypot (claims[i].r - claims[j].r, claims[i].g - claims[j].g);
  std::vector<bool> alive (n, true);
  while (true)
  {
    std::size_t a = n, b = n;
    float best = distance;
    for (std::size_t i = 0; i < n; ++i)
      for (std::size_t j = i + 1; j < n; ++j)
        if (alive[i] && alive[j] && far[i * n + j] < best)
        {
          best = far[i * n + j];
          a = i;
          b = j;
        }
    if (a == n)
      break;
    alive[b] = false;  // b joins a (a < b: a group is named by its first claim)
    for (std::size_t k = 0; k < n; ++k)
    {
      group[k] = group[k] == b ? a : group[k];
      far[a * n + k] = far[k * n + a] = std::max (far[a * n + k], far[b * n + k]);
    }
  }
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

/** Whether chromaticity \a rg lies within \a radius of \a centre (the uniformity tests). */
inline bool
withinRadius (const cv::Point2f& rg, const cv::Point2f& centre, float radius)
{
  const cv::Point2f d = rg - centre;
  return d.dot (d) <= radius * radius;
}

/** The colour leaves of \a pixels: two-means, and each part again while its two means lie
  * at least \a distance apart or it is not one uniform colour (kUniformShare within a
  * quarter of \a distance of its mean: four books of four colours on a shelf, two of them
  * less than \a distance apart), at most \a levels deep; \a centres gets each leaf's mean. */
void
colorLeaves (const std::vector<cv::Point2f>& pixels, float distance, int levels, std::vector<cv::Point2f>& centres)
{
  cv::Point2f mean (0.f, 0.f);
  for (const cv::Point2f& c : pixels)
    mean += c;
  mean *= 1.f / static_cast<float> (std::max<std::size_t> (pixels.size (), 1));
  if (pixels.size () >= 2 && levels > 0)
  {
    std::vector<std::uint8_t> side;
    cv::Point2f centre[2];
    twoMeans (pixels, side, centre);
    const cv::Point2f gap = centre[0] - centre[1];
    std::vector<cv::Point2f> part[2];
    for (std::size_t i = 0; i < pixels.size (); ++i)
      part[side[i]].push_back (pixels[i]);
    const auto uniform = [&] {
      const auto near = std::count_if (pixels.begin (), pixels.end (),
                                       [&] (const cv::Point2f& p) { return withinRadius (p, mean, distance / 4.f); });
      return static_cast<double> (near) >= kUniformShare * static_cast<double> (pixels.size ());
    };
    if ((std::sqrt (gap.dot (gap)) >= distance || !uniform ()) && !part[0].empty () && !part[1].empty ())
    {
      for (const auto& p : part)
        colorLeaves (p, distance, levels - 1, centres);
      return;
    }
  }
  centres.push_back (mean);
}

constexpr double kCoherentShare = 0.8;
/** Pixels of a segment the colour test looks at, at most (evenly spaced). */
constexpr std::size_t kSample = 2048;

/** A pixel's rg chromaticity; false where it is too dark to have one (kMinMeanBrightness). */
inline bool
chromaticity (const cv::Vec3b& bgr, cv::Point2f& rg)
{
  const float total = static_cast<float> (bgr[0]) + bgr[1] + bgr[2];
  if (total < 3.f * static_cast<float> (kMinMeanBrightness))
    return false;
  rg = cv::Point2f (bgr[2] / total, bgr[1] / total);
  return true;
}

/** The largest 4-connected region of \a part (CV_8U, 1 = in) after a 3×3 opening, as
  * \a region (255 = in); returns its pixels, 0 when none. */
int
largestRegion (cv::Mat& part, cv::Mat& region)
{
  cv::Mat labels, stats, centroids;
  cv::morphologyEx (part, part, cv::MORPH_OPEN, cv::Mat::ones (3, 3, CV_8U));
  const int found = cv::connectedComponentsWithStats (part, labels, stats, centroids, 4, CV_32S);
  int largest = 0;
  for (int c = 1; c < found; ++c)
    if (!largest || stats.at<int> (c, cv::CC_STAT_AREA) > stats.at<int> (largest, cv::CC_STAT_AREA))
      largest = c;
  if (!largest)
    return 0;
  region = labels == largest;
  return stats.at<int> (largest, cv::CC_STAT_AREA);
}

/** Levels of two-means a segment's colours are divided to (up to 2^3 colours). */
constexpr int kColorLevels = 3;

/** divideSegmentsByColor() for a segment of more than two colours: segment \a l (pixels in
  * \a box; its colour sample \a list, every \a stride-th pixel) with colour leaves
  * \a centres (colorLeaves). Each leaf of split_min_pixels or more must be one uniform
  * colour (kUniformShare within a quarter of color_split_distance of its mean), at least
  * two such, together kUniformShare of the segment: a segment made of flat colours (books
  * side by side on a shelf, seen as one surface from afar), not print or texture. Then
  * each of them but the largest takes a new label (++\a next in \a divided) over its largest
  * region where that holds kCoherentShare of its pixels. Returns whether one did. */
bool
divideIntoColors (const InstanceGuidedRegionMergeConfig& config, const cv::Mat& geometric, const cv::Mat& color, std::int32_t l,
                  const cv::Rect& box, const std::vector<cv::Point2f>& list, std::size_t stride,
                  const std::vector<cv::Point2f>& centres, cv::Mat& divided, std::int32_t& next)
{
  const float radius = config.color_split_distance / 4.f;
  const auto nearest = [&] (const cv::Point2f& rg) {
    std::size_t best = 0;
    for (std::size_t k = 1; k < centres.size (); ++k)
    {
      const cv::Point2f a = rg - centres[k], b = rg - centres[best];
      best = a.dot (a) < b.dot (b) ? k : best;
    }
    return best;
  };
  std::vector<int> count (centres.size (), 0), near (centres.size (), 0);
  for (const cv::Point2f& rg : list)
  {
    const std::size_t k = nearest (rg);
    ++count[k];
    near[k] += withinRadius (rg, centres[k], radius) ? 1 : 0;
  }
  const auto min_samples = static_cast<int> ((static_cast<std::size_t> (config.split_min_pixels) + stride - 1) / stride);
  std::vector<std::size_t> large;
  int flat = 0;
  for (std::size_t k = 0; k < centres.size (); ++k)
    if (count[k] >= min_samples)
    {
      if (near[k] < kUniformShare * count[k])
        return false;  // print or texture
      large.push_back (k);
      flat += count[k];
    }
  if (large.size () < 2 || flat < kUniformShare * static_cast<double> (list.size ()))
    return false;
  std::vector<cv::Mat> part (centres.size ());
  std::vector<int> pixels (centres.size (), 0);
  for (const std::size_t k : large)
    part[k] = cv::Mat (box.size (), CV_8U, cv::Scalar (0));
  for (int y = 0; y < box.height; ++y)
    for (int x = 0; x < box.width; ++x)
    {
      cv::Point2f rg;
      if (geometric.at<std::int32_t> (box.y + y, box.x + x) != l || !chromaticity (color.at<cv::Vec3b> (box.y + y, box.x + x), rg))
        continue;
      const std::size_t k = nearest (rg);
      if (!part[k].empty ())
      {
        part[k].at<std::uint8_t> (y, x) = 1;
        ++pixels[k];
      }
    }
  const std::size_t keeper = *std::max_element (large.begin (), large.end (), [&] (std::size_t a, std::size_t b) { return pixels[a] < pixels[b]; });
  bool any = false;
  for (const std::size_t k : large)
  {
    if (k == keeper)
      continue;
    cv::Mat region;
    const int area = largestRegion (part[k], region);
    if (area < kCoherentShare * pixels[k] || area < config.split_min_pixels)
      continue;
    if (divided.empty ())
      divided = geometric.clone ();
    divided (box).setTo (cv::Scalar (++next), region);
    any = true;
  }
  return any;
}

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
  * (rg chromaticity ignores it). A segment of more than two colours (colorLeaves finds
  * more than two) is divided by divideIntoColors instead. */
bool
divideSegmentsByColor (const InstanceGuidedRegionMergeConfig& config, const cv::Mat& geometric, const cv::Mat& color,
                       const OverlapTable<int>& owned, cv::Mat& divided)
{
  // The colour statistics look at most kSample pixels of a segment, evenly spaced in
  // raster order: a segment of one colour (nearly all of them) costs one pass over them.
  std::vector<std::size_t> stride (owned.labels (), 0), skip (owned.labels (), 0);  // stride 0: not claimed
  for (std::size_t l = 1; l < owned.labels (); ++l)
    if (owned.size[l] >= 2 * config.split_min_pixels && 2 * owned.best (l).second > owned.size[l])
      stride[l] = (static_cast<std::size_t> (owned.size[l]) + kSample - 1) / kSample;
  std::vector<std::vector<cv::Point2f>> sample (owned.labels ());
  std::vector<cv::Vec4i> bounds (owned.labels (), cv::Vec4i (INT_MAX, INT_MAX, -1, -1));  // x0, y0, x1, y1
  // By runs of one label along a row: the run's ends widen the box, and the samples are
  // every stride[l]-th pixel of the segment in raster order (skip[l]: pixels before its
  // next sample), with no division per pixel.
  for (int y = 0; y < geometric.rows; ++y)
  {
    const std::int32_t* g = geometric.ptr<std::int32_t> (y);
    const cv::Vec3b* bgr = color.ptr<cv::Vec3b> (y);
    for (int x = 0; x < geometric.cols;)
    {
      const std::int32_t label = g[x];
      int end = x + 1;
      while (end < geometric.cols && g[end] == label)
        ++end;
      const auto l = static_cast<std::size_t> (std::max (label, 0));
      if (label > 0 && stride[l])
      {
        cv::Vec4i& b = bounds[l];
        b = cv::Vec4i (std::min (b[0], x), std::min (b[1], y), std::max (b[2], end - 1), std::max (b[3], y));
        const auto run = static_cast<std::size_t> (end - x);
        std::size_t k = skip[l];
        for (cv::Point2f rg; k < run; k += stride[l])
          if (chromaticity (bgr[x + static_cast<int> (k)], rg))
            sample[l].push_back (rg);
        skip[l] = k - run;
      }
      x = end;
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
    const cv::Vec4i& b = bounds[l];
    const cv::Rect box (b[0], b[1], b[2] - b[0] + 1, b[3] - b[1] + 1);
    // More than two colours (a part's two means apart again): divideIntoColors. The first
    // level is the two-means just made; colorLeaves goes on from its parts.
    std::vector<cv::Point2f> part_samples[2], centres;
    for (std::size_t i = 0; i < list.size (); ++i)
      part_samples[side[i]].push_back (list[i]);
    if (!part_samples[0].empty () && !part_samples[1].empty ())
      for (const auto& samples : part_samples)
        colorLeaves (samples, distance, kColorLevels - 1, centres);
    if (centres.size () > 2)
    {
      any = divideIntoColors (config, geometric, color, static_cast<std::int32_t> (l), box, list, stride[l], centres, divided, next) || any;
      continue;
    }
    int count[2] = {0, 0}, near[2] = {0, 0};
    for (std::size_t i = 0; i < list.size (); ++i)
    {
      ++count[side[i]];
      near[side[i]] += withinRadius (list[i], centre[side[i]], radius) ? 1 : 0;
    }
    bool divide = true;
    for (int k = 0; k < 2; ++k)
      divide = divide && count[k] >= config.color_split_share * static_cast<double> (list.size ()) &&
               near[k] >= kUniformShare * count[k];
    if (!divide)
      continue;
    // Every bright pixel of the segment to its nearer mean; each part must be one region:
    // the largest 4-connected component of its opened pixels.
    cv::Mat part[2] = {cv::Mat (box.size (), CV_8U, cv::Scalar (0)), cv::Mat (box.size (), CV_8U, cv::Scalar (0))};
    int pixels[2] = {0, 0};
    for (int y = 0; y < box.height; ++y)
      for (int x = 0; x < box.width; ++x)
      {
        cv::Point2f rg;
        if (geometric.at<std::int32_t> (box.y + y, box.x + x) != static_cast<std::int32_t> (l) ||
            !chromaticity (color.at<cv::Vec3b> (box.y + y, box.x + x), rg))
          continue;
        const cv::Point2f d0 = rg - centre[0], d1 = rg - centre[1];
        const int k = d1.dot (d1) < d0.dot (d0) ? 1 : 0;
        part[k].at<std::uint8_t> (y, x) = 1;
        ++pixels[k];
      }
    cv::Mat region[2];
    for (int k = 0; k < 2 && divide; ++k)
    {
      const int area = largestRegion (part[k], region[k]);
      divide = area > 0 && area >= kCoherentShare * pixels[k];
    }
    if (!divide)
      continue;
    if (divided.empty ())
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
}  // namespace detail

using namespace detail;

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
}  // namespace segmentation
}  // namespace cuefusion
