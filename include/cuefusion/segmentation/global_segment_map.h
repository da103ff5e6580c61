// SPDX-License-Identifier: BSD-3-Clause
#pragma once

#include <cuefusion/segmentation/instance_guided_region_merge.h>
#include <cuefusion/segmentation/voxel_label_layer.h>

#include <Eigen/Geometry>

#include <cstddef>
#include <cstdint>
#include <memory>
#include <map>
#include <optional>
#include <string>
#include <tuple>
#include <unordered_map>
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
/** \brief Equivalence of global segment labels (union–find). Objects are groups of map
  * segments; a label read from the volume is resolved through find(), so grouping never
  * rewrites a voxel. find() only reads (threads may share it). The grouping follows the
  * evidence and may change: clear() forgets every link and the map links again the pairs
  * the evidence unites (GlobalSegmentMap::regroup).
  */
class LabelEquivalence
{
public:
  /** \brief The label \a label stands for now (itself when never merged; 0 stays 0). */
  std::uint32_t find (std::uint32_t label) const;

  /** \brief After this, \a b and everything merged into it resolve to the smaller of the
    * two roots (a segment keeps its first id). Returns the surviving label.
    */
  std::uint32_t unite (std::uint32_t a, std::uint32_t b);

  /** \brief Points every label straight at its root. */
  void compact ();

  /** \brief Every label its own root again. */
  void clear () { parent_.clear (); }

private:
  std::vector<std::uint32_t> parent_;  ///< by label; labels beyond the end are their own root
};

/** \brief Parameters of segment grouping (§4.2.3, as evidence). */
struct GlobalSegmentMapConfig
{
  /** Frames that must show a pair as one object before it is united (the thesis confirms
    * a merge at Ψ^m = 5).
    */
  int confirm_confidence = 5;
  /** A pair stays united only while more than this share of the frames that judged it
    * saw it as one object.
    */
  float together_share = 0.5f;
  /** An object is confirmed (shown as itself in outputs, GlobalSegmentMap::settledLabels)
    * when its labels were seen in at least confirm_confidence frames and in at least this
    * share of the frames that observed its surface (the mean TSDF weight of its voxels:
    * one per integration, up to w_max). A splinter that a frame segment carried in 5 of
    * the 100 frames its surface was fused is noise, not an object; it settles into the
    * object it touches. 0 = confirm_confidence alone (before 0.4).
    */
  float confirm_share = 0.2f;
  /** One flat surface that furniture or objects part in every view (a floor around a
    * kitchen island, a wall beside a bookshelf, a table top between the things on it)
    * shows as one object in outputs (settledLabels): two objects no mask gave a class,
    * each flat and at least this wide (m) in both directions of its plane, on one plane,
    * that the evidence has not judged (fewer than confirm_confidence votes on them: no
    * frame saw them touch, or hardly any), with no free space and no third surface on
    * the plane between them (where a camera looked through: two tables at one height; a
    * third door between two). A flat object no mask gave a class that is narrower than
    * this joins the larger such object it touches when that one's surface continues its
    * plane around it (a strip of a floor seen between the slats of a chair's back) and the
    * evidence has not judged them. 0 = off, patches too (before 0.5).
    */
  float surface_min_extent = 0.3f;
  /** A flat surface has 90 % of its voxels within this distance (m) of its plane; two are
    * on one plane when each centroid is within it of the other's plane; free space is
    * further than it from every surface.
    */
  float surface_tolerance = 0.02f;
  /** Two flat surfaces are on one plane only when their normals are within this angle. */
  float surface_max_angle_deg = 5.f;
  void validate () const;
};
/// The name before 0.2 (one config per class, named after it).
using SegmentMergingConfig [[deprecated ("renamed GlobalSegmentMapConfig")]] = GlobalSegmentMapConfig;

/** \brief What one frame says of a pair of map segments it sees. */
enum class PairVote
{
  Together,  ///< one frame segment holds both, or one instance mask covers both
  Apart      ///< the masks separate them, or an edge does where no mask speaks
};

/** \brief Frames for and against each pair of map segments being one object, kept for the
  * whole run (voxblox++ keeps pairwise counts the same way). The thesis's Ψ^m only counts
  * frames for a merge and forgets them when the pair is unseen, so a detector that merges
  * two touching objects in five frames out of fifty merges them for good; here the
  * frames that see them apart outvote it, and a merge the evidence no longer supports is
  * undone.
  */
class PairEvidence
{
public:
  struct Counts
  {
    int together = 0, apart = 0;
  };
  explicit PairEvidence (const GlobalSegmentMapConfig& config = GlobalSegmentMapConfig ());

  /** \brief One vote of the current frame (each pair once per frame: the caller's job).
    * Returns whether it changed the pair's verdict (united()).
    */
  bool add (std::uint32_t a, std::uint32_t b, PairVote vote);
  Counts counts (std::uint32_t a, std::uint32_t b) const;
  /** \brief Whether the evidence unites \a a and \a b: at least confirm_confidence frames
    * together and together > together_share · (together + apart).
    */
  bool united (std::uint32_t a, std::uint32_t b) const;
  bool united (const Counts& counts) const;
  /** \brief Whether the pair has been voted on at all. */
  bool tracked (std::uint32_t a, std::uint32_t b) const;
  std::size_t trackedPairs () const { return counts_.size (); }
  const GlobalSegmentMapConfig& getConfig () const { return config_; }
  const std::map<std::pair<std::uint32_t, std::uint32_t>, Counts>& pairs () const { return counts_; }

private:
  GlobalSegmentMapConfig config_;
  std::map<std::pair<std::uint32_t, std::uint32_t>, Counts> counts_;  ///< by (smaller, larger) label
};

/** \brief What the map knows of one global segment. */
struct SegmentRecord
{
  std::uint32_t id = 0;
  std::size_t first_frame = 0, last_frame = 0;
  /** Frames in which a frame segment carried this label (for an object: the most any of
    * its labels was seen). */
  std::size_t frames_seen = 0;
  /** Instance-cue votes: class name → (frames, summed score). The thesis discards the
    * class; it is kept here.
    */
  std::map<std::string, std::pair<int, float>> class_votes;
  /** From a loaded volume (FusionPipeline::continueFrom): an object of the saved map,
    * kept as one whatever this run sees of it; its frames count this run only. */
  bool loaded = false;
  std::size_t voxels = 0;                ///< from refreshStatistics
  Eigen::AlignedBox3f bounds;            ///< world frame, from refreshStatistics

  /** \brief The class with the most votes (higher summed score on a tie), "" if none or
    * if it was voted in fewer than a quarter of the frames the segment was seen (a floor
    * that one stray mask claimed once is no teddy bear).
    */
  std::string bestClass () const;
  /** \brief Mean score of the best class over the frames that voted for it. */
  float bestScore () const;
};

/** \brief The registry of global segments (the GSM of §4.2): label allocation, the
  * evidence for and against grouping pairs of segments into one object, the grouping it
  * gives (LabelEquivalence), and per segment its frames, class votes, voxel count and
  * bounds. Records are kept per label as allocated; segments() and record() report each
  * object (a group) as one record under its smallest label.
  */
class GlobalSegmentMap
{
public:
  using Ptr = std::shared_ptr<GlobalSegmentMap>;
  using ConstPtr = std::shared_ptr<const GlobalSegmentMap>;

  explicit GlobalSegmentMap (const GlobalSegmentMapConfig& merging = GlobalSegmentMapConfig ());

  /** \brief A fresh global label, first seen at \a frame. */
  std::uint32_t newSegment (std::size_t frame);

  /** \brief A fresh global label for an object of a loaded map (SegmentRecord::loaded):
    * confirmed from the start, never settled into another object. */
  std::uint32_t newLoadedSegment (std::size_t frame);

  /** \brief \a label was seen at \a frame, with instance-cue class info when the frame
    * segment carried one (instance ≥ 0).
    */
  void observe (std::uint32_t label, std::size_t frame, const SegmentInstance* info = nullptr);

  /** \brief One frame's votes on pairs of (unresolved) labels, then the grouping is
    * recomputed from all the evidence (regroup). Returns how many labels now resolve to
    * another label than before this frame (merges made plus merges undone).
    */
  std::size_t addEvidence (const std::vector<std::tuple<std::uint32_t, std::uint32_t, PairVote>>& votes);

  /** \brief Unites \a a and \a b for good, whatever the evidence (a user's correction or
    * a test); returns the surviving label. No voxel is written.
    */
  std::uint32_t merge (std::uint32_t a, std::uint32_t b);

  /** \brief The labels made for frame segments that the masks set apart from the ones
    * keeping \a label (SegmentPropagation), oldest first: while the voxels still carry
    * \a label, the same objects get the same labels frame after frame.
    */
  const std::vector<std::uint32_t>& successors (std::uint32_t label) const;
  /** \brief A fresh label, first seen at \a frame, recorded as a successor of \a label. */
  std::uint32_t newSuccessor (std::uint32_t label, std::size_t frame);

  std::uint32_t resolve (std::uint32_t label) const { return equivalence_.find (label); }
  const LabelEquivalence& equivalence () const { return equivalence_; }
  const PairEvidence& evidence () const { return evidence_; }
  std::size_t labelsAllocated () const { return next_label_ - 1; }

  /** \brief Voxel counts and world bounds of every segment from the label layer \a labels
    * of \a volume (labels as stored; voxels with no weight or no label are skipped).
    */
  void refreshStatistics (const reconstruction::TSDFVolume& volume, const VoxelLabelLayer& labels);

  /** \brief One record per object (group of labels), under its smallest label, in
    * increasing id: frames, class votes, voxels and bounds of its labels combined. With
    * \a settled (from settledLabels), labels count for the object they settle to, and
    * labels settled to 0 are left out.
    */
  std::vector<SegmentRecord> segments (const std::unordered_map<std::uint32_t, std::uint32_t>* settled = nullptr) const;

  /** \brief What each label shows as in outputs: the object it belongs to when that object
    * was loaded or is confirmed (GlobalSegmentMapConfig::confirm_confidence and
    * confirm_share, and some label of it on the map's surface: the nearer voxel of a zero
    * crossing, which labels the crossing's point; an object left only in voxels of the
    * truncation band shows in no point of map.pcd or the mesh); otherwise (a fragment not confirmed: the rim of a surface at the edge of the view, a noise patch, a splinter
    * born in the last frames of a run) the confirmed object whose voxels its voxels touch
    * most (6-neighbourhood in \a volume, followed through other fragments); where it
    * touches none, itself while it is still being seen (its last frame less than
    * confirm_confidence frames before the latest), else 0. Then objects whose labels'
    * votes, summed over all their pairs, unite them (PairEvidence::united) with fewer
    * than confirm_confidence votes apart, and that the masks gave the same class or
    * none, show as one: a surface seen at a grazing angle
    * takes a fresh label in most frames, and its votes spread over many label pairs that
    * none reaches confirm_confidence alone. Last, objects that are one
    * flat surface parted in every view (a floor around an island, a wall beside a
    * shelf) show as one (GlobalSegmentMapConfig::surface_min_extent). Labels not in the
    * result are 0. Reads the volume; nothing is written, so a fragment confirmed later
    * shows as itself. (Before 0.4 a fragment still being seen showed as itself whatever it
    * touched: the 7-Scenes kitchen's map kept 72 such splinters of ≥ 100 voxels born in
    * its last frames.)
    */
  std::unordered_map<std::uint32_t, std::uint32_t> settledLabels (const reconstruction::TSDFVolume& volume,
                                                                  const VoxelLabelLayer& labels) const;
  /** \brief The record of the object \a label belongs to; none for an unknown label. */
  std::optional<SegmentRecord> record (std::uint32_t label) const;

private:
  /** \brief Rebuilds the equivalence from the evidence and the pinned merges. */
  void regroup ();

  /** \brief settledLabels(): objects (\a shown: label → object, 0 none) that the evidence
    * unites once its votes are summed over their labels' pairs, with fewer than
    * confirm_confidence of them apart and one class (or none) for both, show as one (the
    * smallest object of the group); a group never holds two objects the summed votes
    * judge apart. */
  void uniteBySummedEvidence (std::vector<std::uint32_t>& shown) const;

  std::uint32_t next_label_ = 1;
  std::size_t latest_frame_ = 0;  ///< the latest frame a segment was seen or made in
  LabelEquivalence equivalence_;
  PairEvidence evidence_;
  std::vector<std::pair<std::uint32_t, std::uint32_t>> pinned_;  ///< merge() calls
  std::map<std::uint32_t, std::vector<std::uint32_t>> successors_;
  std::map<std::uint32_t, SegmentRecord> records_;  ///< by label as allocated
};
}  // namespace segmentation
}  // namespace cuefusion
