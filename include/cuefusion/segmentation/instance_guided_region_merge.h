// SPDX-License-Identifier: BSD-3-Clause
#pragma once

#include <cuefusion/common/exceptions.h>
#include <cuefusion/common/instance.h>
#include <cuefusion/common/sensor_defaults.h>
#include <cuefusion/segmentation/surface_planes.h>

#include <opencv2/core.hpp>

#include <pcl/point_cloud.h>

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

namespace cuefusion
{
namespace segmentation
{
/** \brief Parameters of InstanceGuidedRegionMerge (§4.2.1.3). */
struct InstanceGuidedRegionMergeConfig
{
  float min_overlap = 0.70f;  ///< α(l_s, l_g) must exceed this for l_g to join instance l_s
  /** A geometric segment is cut along the masks where two or more instances each cover at
    * least this share of it (and split_min_pixels), or — where the masks tile it — hold
    * more than min_overlap of their own masks' pixels on segments (however few: books
    * flush on a shelf): the masks see objects where geometry saw no edge (touching boxes
    * with coplanar faces). The masks do not tile it where its pixels beyond twice
    * mask_boundary_tolerance of every mask are this share of it too (and
    * split_min_pixels); those pixels, up to the masks, then stay one piece of their own
    * (split() says more).
    */
  float split_share = 0.2f;
  int split_min_pixels = 50;  ///< and at least this many pixels
  /** merge() with the frame's points: pieces one mask covers that meet mostly along a
    * depth jump (one in front of the other) are kept apart when both hold at least this
    * share of the mask's pieces — two objects the network reported as one; a small part
    * hanging on a larger one (an ear, a bottle's neck) and pieces meeting at a crease are
    * still united. Above 0.5 it never applies. merge() only (segment-frame's fused mode):
    * the pipeline calls split(), which leaves the grouping to the map over frames, so this
    * has no effect there.
    */
  float occlusion_split_share = 0.25f;
  /** How far (pixels) a mask's boundary may be off: a piece the masks cover only in part
    * (between 1 − min_overlap and min_overlap of it) is claimed when more than
    * min_overlap of it lies inside its best instance's mask or within this many pixels of
    * it. A network's masks are decoded at half resolution and grown, so their boundary is
    * a pixel or two off; without this, the keys along a keyboard's rim, a lid's edge or a
    * handle that the mask misses by a pixel stay segments of their own. A neighbour that
    * a leaking mask overlaps keeps its pixels beyond the band and stays apart. 0 = off.
    */
  int mask_boundary_tolerance = 2;
  /** With the frame's colour: a mask is cut where the geometric segments it claims (more
    * than half of each inside it) fall into groups whose mean colours lie more than this
    * apart in rg chromaticity (r = R/(R+G+B), g = G/(R+G+B): shading scales all three
    * channels and leaves it unchanged). A depth network merges touching objects it cannot
    * tell from one object with a crease (two boxes flush, a box on a box, an L-block);
    * distinctly coloured ones are cut apart again, while an object's parts of one colour
    * stay together. 0 = off. At 0.2 only clearly different hues cut (orange and teal lie
    * 0.5 apart, green and violet 0.25); a real white-and-red object of osd-learn measured
    * 0.14–0.16 between its parts and was cut in two at 0.1 and 0.15 (docs/benchmarks.md).
    * A claimed segment that is itself made of two such colours side by side, each uniform
    * (the coplanar fronts of two boxes flush, one segment of L^G), is divided first
    * (divideByColor).
    */
  float color_split_distance = 0.2f;
  /** ... and only when at least two such colour groups each hold this share of the
    * pixels the mask claims: a differently coloured cap, handle or label stays with its
    * object.
    */
  float color_split_share = 0.2f;
  /** Neighbouring pixels further apart in depth than this × z meet along a depth jump,
    * not on one surface (the mask's rim is grown only across one surface; a mask divided
    * along jumps is two objects): the same 2 % as EdgeLabelingConfig::max_depth_jump. */
  float max_depth_jump = kSurfaceDepthJump;
  /** Where the normals are noisier than the concavity test's threshold (beyond about
    * 1.25 m at the Kinect model's noise; see noise_ratio), the rim grows from a pixel to
    * its neighbour only where their normals lie within this angle, in degrees (a pixel
    * without a normal joins the rim, which stops there; 180 = normals not looked at, the
    * rim of before 2026-11-27): on one surface, not across the edge band where an object
    * stands on a table. A network's mask is a few pixels too large, the band at an
    * object's base continues in depth on both sides, and far away it is wide: the rim
    * took a ring of table into every far object's segment (generated clutter at 2.4-3.2
    * m, median mean object IoU 0.65 -> 0.78). 16 was chosen among 11, 16 and 26 on seeds
    * 1-3 of those draws and checked on seeds 4-6 (docs/benchmarks.md, 2026-11-27
    * evening); nearer views are not touched. */
  float rim_max_normal_angle_deg = 16.f;
  /** The depth noise over the Kinect model's (reconstruction::estimateDepthNoise): 1 =
    * Kinect-class, 0 = exact depth. It says where the normals are noisy enough for the
    * rim's normal test (rim_max_normal_angle_deg). FusionPipeline sets the ratio it
    * measures when GeometricSegmentationConfig::noise_scale is 0 (measured, the default). */
  float noise_ratio = 1.f;
  void validate () const;
};
/// The name before 0.2 (one config per class, named after it).
using InstanceGuidedMergeConfig [[deprecated ("renamed InstanceGuidedRegionMergeConfig")]] = InstanceGuidedRegionMergeConfig;

/** \brief What one segment of L_t is: the instance it was merged under (class and score
  * from the instance cue), or a purely geometric segment (instance −1, class −1).
  */
struct SegmentInstance
{
  int instance = -1;         ///< index into the instances given to merge(), −1 = none
  int class_id = -1;
  std::string class_name;
  float score = 0.f;
  int geometric_segments = 0;  ///< how many segments of L^G it unites
  /** Share of the segment under the instance that covers most of it (also when below
    * min_overlap): above min_overlap the masks claim it, below 1 − min_overlap they leave
    * it out, in between they are unsure.
    */
  float coverage = 0.f;
};

/** \brief Fuses the geometric label map L^G with instance masks into L_t (§4.2.1.3).
  *
  * For each geometric segment l_g, α(l_s, l_g) = |l_g ∩ l_s| / |l_g| for every instance
  * l_s, and the instance with the largest α is kept. All segments whose best instance is
  * the same l_s with α > min_overlap become one segment of L_t carrying that instance's
  * class and score; the others stay as they are (geometry still separates what the network
  * does not know, §2.1.3). Where masks overlap, the higher score owns the pixel. Pixels
  * that are 0 in L^G stay 0, except where a mask completes a rim or gives back an object
  * geometry lost whole (split()): the masks group segments, they do not draw new
  * boundaries through them.
  * Output labels are 1..M in raster order of each segment's first pixel, so the result
  * depends only on the inputs.
  *
  * Before uniting, segments that two masks share substantially are cut along the masks
  * (split()): geometry's boundaries are kept, and the masks add the ones geometry cannot
  * see. A mask that covers two objects (thesis Fig. 5.19) unites them when each object's
  * segments lie more than min_overlap inside it: one frame cannot tell that from an
  * object geometry splits (an L, a teddy); over a sequence the map weighs every frame's
  * word (GlobalSegmentMap). A mask that leaks onto the table does not take the table:
  * the leak is a small part of the table's segment.
  */
class InstanceGuidedRegionMerge
{
public:
  using Ptr = std::shared_ptr<InstanceGuidedRegionMerge>;
  using ConstPtr = std::shared_ptr<const InstanceGuidedRegionMerge>;

  explicit InstanceGuidedRegionMerge (const InstanceGuidedRegionMergeConfig& config = InstanceGuidedRegionMergeConfig ());

  void setConfig (const InstanceGuidedRegionMergeConfig& config);
  const InstanceGuidedRegionMergeConfig& getConfig () const { return config_; }

  /** \param[in] geometric L^G, CV_32S, 0 = no segment
    * \param[in] instances masks of the frame's size (CV_8U); may be empty (then L_t = L^G
    *            relabelled in raster order, which leaves OpenCV-numbered L^G unchanged)
    * \param[out] fused L_t, CV_32S
    * \param[out] segments when given: entry l describes label l of L_t (entry 0 unused)
    * \param[in] planes the frame's points, when at hand: the masks complete rims (see
    *            split()) and pieces meeting along depth jumps may stay apart
    *            (occlusion_split_share)
    * \param[in] color the frame's colour (CV_8UC3, BGR, L^G's size), when at hand: masks
    *            are first divided by colour (divideByColor); SegmentInstance::instance
    *            then indexes the divided list (the given instances keep their indices,
    *            the parts cut off follow them)
    * Throws cuefusion::Error on a label map that is not CV_32S or masks of another size.
    */
  void merge (const cv::Mat& geometric, const std::vector<Instance>& instances, cv::Mat& fused,
              std::vector<SegmentInstance>* segments = nullptr, const SurfacePlanes* planes = nullptr,
              const cv::Mat& color = cv::Mat ()) const;

  /** \brief merge() on organized PCL label clouds (e.g. from GeometricSegmentation::segment):
    * \a fused gets \a geometric's points with the labels of L_t (it may be \a geometric).
    * Any point type with a label field.
    */
  template <typename PointLT>
  void
  merge (const pcl::PointCloud<PointLT>& geometric, const std::vector<Instance>& instances,
         pcl::PointCloud<PointLT>& fused, std::vector<SegmentInstance>* segments = nullptr) const
  {
    if (!geometric.isOrganized () || geometric.size () != static_cast<std::size_t> (geometric.width) * geometric.height)
      throw Error ("InstanceGuidedRegionMerge", "the label cloud is not organized");
    cv::Mat labels (static_cast<int> (geometric.height), static_cast<int> (geometric.width), CV_32S), out;
    for (std::size_t i = 0; i < geometric.size (); ++i)
      reinterpret_cast<std::int32_t*> (labels.data)[i] = static_cast<std::int32_t> (geometric[i].label);
    merge (labels, instances, out, segments);
    if (&fused != &geometric)
      fused = geometric;
    for (std::size_t i = 0; i < fused.size (); ++i)
      fused[i].label = static_cast<std::uint32_t> (reinterpret_cast<const std::int32_t*> (out.data)[i]);
  }

  /** \brief The first half of merge(): L^G with every segment that two or more instances
    * each cover substantially cut along the masks, no segments united. Substantially:
    * split_share of it and split_min_pixels; or, where the masks tile the segment, more
    * than min_overlap of the mask's own pixels on segments, unless more than half of
    * the mask lies inside one other mask. Tiling: the segment's pixels more than twice
    * mask_boundary_tolerance from every qualifying mask (4-connected, inside the
    * segment) are fewer than split_share of it or split_min_pixels; where they are not,
    * those pixels, up to the masks, are one piece of their own. Each qualifying
    * instance takes its pixels of the segment; the segment's other pixels go to the
    * nearest part (4-connected, inside the segment).
    * Labels 1..N in raster order; \a segments, when given, says for each which instance
    * covers it (instance ≥ 0 when its coverage exceeds min_overlap) and how much. These
    * are the pieces FusionPipeline carries into the map, where the masks' grouping is
    * evidence rather than a verdict (GlobalSegmentMap).
    *
    * With the frame's points (\a planes), pixels L^G leaves 0 although they have a point
    * (the edge band that edge assignment did not give back) join a piece its instance
    * claims when they lie inside that instance's mask and connect to the piece through
    * such pixels without a depth jump (> 2 % of the depth, the rule the normals use) and,
    * where the planes hold normals, with neighbouring normals within
    * rim_max_normal_angle_deg, breadth-first: the masks complete an object's rim on the
    * side it continues in depth and in orientation; they still draw no boundary through a
    * segment of L^G. An instance that then claims no piece although more than
    * min_overlap of its mask's pixels with a point (and split_min_pixels) are 0-pixels
    * marks an object geometry lost whole (a small or far one whose interior fell under
    * min_segment_size or inside the edge band): a piece of its own grows by the same step
    * from the mask's innermost such pixel and is kept, after the numbered pieces, when it
    * reaches split_min_pixels and does not continue a piece another instance claims
    * (continuing: more than half of the pixel pairs along their shared boundary step on
    * one surface — a second mask over part of that object). Labels are then 1..N in
    * raster order followed by these.
    */
  void split (const cv::Mat& geometric, const std::vector<Instance>& instances, cv::Mat& pieces,
              std::vector<SegmentInstance>* segments = nullptr, const SurfacePlanes* planes = nullptr,
              const cv::Mat& color = cv::Mat ()) const;

  /** \brief The instances with every mask that claims geometric segments of clearly
    * different colours cut into one mask per colour (color_split_distance,
    * color_split_share); merge() and split() do this first when given the colour.
    *
    * First, each segment of L^G a mask claims is divided where it is two uniform colours
    * side by side: two-means of its pixels' rg chromaticity (pixels darker than a mean of
    * 20 of 255 left out), divided when the means lie at least color_split_distance apart,
    * each part holds color_split_share of the pixels, 80 % of each part lies within a
    * quarter of that distance of its mean (one flat colour, not print or texture) and 80 %
    * of each part is one 4-connected region after a 3×3 opening; the smaller part's region
    * becomes a segment of its own. Geometry cannot see a seam between coplanar faces of
    * two objects; their colours can. Where either part's two means lie that far apart
    * again (more than two colours: books side by side on a shelf seen from afar), two-means
    * is repeated on each part (up to three levels); each colour of split_min_pixels or more
    * must then be uniform, together at least 80 % of the segment, and each of them but the
    * largest takes its largest region (80 % of its pixels, split_min_pixels) as a segment
    * of its own.
    *
    * A mask claims a segment of L^G when more than half of the segment lies in the pixels
    * it owns (the higher score where masks overlap). Each claimed segment's colour is the
    * mean of its claimed pixels, in rg chromaticity; segments darker than a mean of 20 of
    * 255 have no colour to speak of and stay with the largest group. Groups of segments
    * are joined, closest first, while every colour of one lies within color_split_distance
    * of every colour of the other (complete linkage: no chain of near colours links the
    * first book of a shelf to the last). With two or
    * more groups each holding color_split_share of the claimed pixels, the largest keeps
    * the mask, the others each take their segments' pixels of it as a new Instance (same
    * class and score) appended after the given ones, in order of instance and group.
    * Returns \a instances unchanged when the colour is empty or color_split_distance 0.
    * Throws cuefusion::Error on a colour image that is not CV_8UC3 of L^G's size.
    */
  std::vector<Instance>
  divideByColor (const cv::Mat& geometric, const std::vector<Instance>& instances, const cv::Mat& color) const;

private:
  /** \brief split(), returning the masks it cut along: \a given, or what divideByColor
    * made of them (merge() describes its segments by these). */
  std::vector<Instance>
  splitAlongMasks (const cv::Mat& geometric, const std::vector<Instance>& given, cv::Mat& pieces,
                   std::vector<SegmentInstance>* segments, const SurfacePlanes* planes, const cv::Mat& color) const;

  InstanceGuidedRegionMergeConfig config_;
};
/** \brief The masks alone as segments (the "masks" mode): label i + 1 for instance i,
  * the higher score where masks overlap, on pixels with a point in \a planes only (a
  * segment is a set of 3D points). \a segments, when given, describes each label.
  */
void
masksAsSegments (const std::vector<Instance>& instances, const SurfacePlanes& planes, cv::Mat& labels,
                 std::vector<SegmentInstance>* segments = nullptr);

}  // namespace segmentation
}  // namespace cuefusion
