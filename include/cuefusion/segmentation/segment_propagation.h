// SPDX-License-Identifier: BSD-3-Clause
#pragma once

#include <cuefusion/common/pinhole_camera.h>
#include <cuefusion/segmentation/global_segment_map.h>
#include <cuefusion/segmentation/segment_size.h>
#include <cuefusion/segmentation/voxel_label_update.h>  // the map update that follows (§4.2.4)

#include <opencv2/core.hpp>

#include <Eigen/Geometry>

#include <cstdint>
#include <memory>
#include <tuple>
#include <utility>
#include <vector>

namespace cuefusion
{
namespace reconstruction
{
class TSDFVolume;
}

namespace segmentation
{
/** \brief Parameters of SegmentPropagation (§4.2.2). */
struct SegmentPropagationConfig
{
  float normal_agreement = 0.7f;   ///< τ_N: N(u)·N^m(u) must exceed this
  float inherit_overlap = 0.3f;    ///< τ_l: Π̃ above this inherits the model label
  float noise_factor = 1.f;        ///< the distance test is |(V − V^m)·V/|V|| < k·σ_d(u)
  int min_segment_size = kMinSegmentPixels;///< frame segments with fewer pixels get label 0; map segments seen on fewer get no vote
  /** A map segment counts as seen inside one frame segment when more than this share of
    * its agreeing pixels lie in it; only such segments get votes (§4.2.3 as evidence).
    */
  float placement_share = 0.5f;
  /** A frame segment whose best instance covers less than this share of it is one the
    * masks leave out (1 − InstanceGuidedRegionMergeConfig::min_overlap by default).
    */
  float uncovered_overlap = 0.3f;
  /** Two frame segments no mask speaks for, parted by a geometric edge, are judged on the
    * fused surface (the raycast V^m, N^m): along the samples of their shared boundary
    * where the frame shows a depth jump or a concave crease, Apart when at least this
    * share shows it in the model too, Together when less — the frame's edge was sensor
    * noise the fusion has averaged away (stuff surfaces of a room split by noise: a
    * counter, a cabinet, a floor). Where fewer than 20 samples can be judged (the frame
    * shows no geometric edge there: a cut along a colour boundary; or the model has no
    * surface yet) the frame's word stands: Apart. 0 = every such edge parts them (the
    * behaviour before 0.4).
    */
  float model_edge_share = 0.25f;
  void validate () const;
};

/** \brief Result of one propagation: L^p and the frame's votes on pairs of map segments. */
struct PropagationResult
{
  cv::Mat labels;  ///< L^p, CV_32S global labels (as allocated, not resolved)
  /** What this frame says of pairs of map segments it sees (GlobalSegmentMap::addEvidence). */
  std::vector<std::tuple<std::uint32_t, std::uint32_t, PairVote>> votes;
  int inherited = 0, fresh = 0, dropped = 0;
};

/** \brief Carries frame segments over to the map's global labels (§4.2.2).
  *
  * Π(l_i, l_j) counts the pixels u where frame segment l_j meets model label l_i and the
  * surfaces agree: |(V(u) − V^m(u))·V(u)/|V(u)|| < k·σ_d(u) (the distance along the
  * viewing ray, σ_d the Kinect noise model at u) and N(u)·N^m(u) > τ_N. With Π̃ = Π / #l_j,
  * l_j inherits the l_i of the largest Π̃ when it exceeds τ_l, else it gets a fresh label
  * from the map. Labels are the map's labels as allocated (pieces), not resolved: objects
  * are groups of them, formed from evidence (GlobalSegmentMap).
  *
  * With the masks' word on each frame segment (\a segments, from
  * InstanceGuidedRegionMerge::split: claimed by instance k, left out, or unsure), two
  * frame segments the masks set apart (different instances, or one claimed and one left
  * out) never share a map label: the one with the larger Π keeps it, the others take
  * their next label above τ_l or one fresh label per instance. A label that once covered
  * two touching objects (a merged mask early on) is split again this way.
  *
  * §4.2.3 as evidence: every map segment seen on ≥ min_segment_size agreeing pixels,
  * more than placement_share of them inside one frame segment, is judged against every
  * other such segment: Together when one frame segment holds both, or one instance claims
  * both; Apart when the masks set them apart. When their frame segments touch (an edge
  * between them) and no mask speaks for either, the fused surface decides: Apart where it
  * shows the edge too, Together where it is smooth across (model_edge_share). Apart votes
  * are kept only for pairs the map already tracks or whose frame segments touch.
  *
  * The cost is one pass over the image and a table of the pairs seen: it does not depend
  * on the map's size (§4.2.2.1). Frame labels are handled in increasing order, so fresh
  * labels are deterministic.
  */
class SegmentPropagation
{
public:
  using Ptr = std::shared_ptr<SegmentPropagation>;
  using ConstPtr = std::shared_ptr<const SegmentPropagation>;

  explicit SegmentPropagation (const SegmentPropagationConfig& config = SegmentPropagationConfig ());
  const SegmentPropagationConfig& getConfig () const { return config_; }

  /** \param[in] vertices, normals frame V and N (CV_32FC3, camera frame, NaN = none)
    * \param[in] frame_labels L_t (CV_32S, 0 = none)
    * \param[in] model_vertices, model_normals, model_labels the raycast V^m, N^m, L^m of
    *            the same camera (CV_32FC3, CV_32FC3, CV_32S)
    * \param[in,out] map allocates fresh labels and records what was seen
    * \param[in] frame index, for the map's first/last frame
    * \param[in] segments optional: class info per frame label (from InstanceGuidedRegionMerge)
    */
  void propagate (const cv::Mat& vertices, const cv::Mat& normals, const cv::Mat& frame_labels,
                  const cv::Mat& model_vertices, const cv::Mat& model_normals, const cv::Mat& model_labels,
                  GlobalSegmentMap& map, std::size_t frame, PropagationResult& result,
                  const std::vector<SegmentInstance>* segments = nullptr) const;

private:
  SegmentPropagationConfig config_;
};

}  // namespace segmentation
}  // namespace cuefusion
