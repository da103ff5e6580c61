#pragma once

#include <cuefusion/segmentation/instance_guided_region_merge.h>

#include <Eigen/Geometry>

#include <cstddef>
#include <cstdint>
#include <map>
#include <string>
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
/** \brief Equivalence of global segment labels (union–find). A confirmed merge (§4.2.3)
  * links two labels here instead of rewriting every voxel that carries one of them; a
  * label read from the volume is resolved through find(). find() only reads (threads may
  * share it); compact() points every label at its root, done lazily after merges.
  */
class LabelEquivalence
{
public:
  /** \brief The label \a label stands for now (itself when never merged; 0 stays 0). */
  std::uint32_t find (std::uint32_t label) const;

  /** \brief After this, \a b and everything merged into it resolve to find(a) (the thesis
    * "l_b becomes l_a"). Returns the surviving label.
    */
  std::uint32_t unite (std::uint32_t a, std::uint32_t b);

  /** \brief Points every label straight at its root. */
  void compact ();

private:
  std::vector<std::uint32_t> parent_;  ///< by label; labels beyond the end are their own root
};

/** \brief Parameters of segment merging (§4.2.3). */
struct SegmentMergingConfig
{
  float candidate_overlap = 0.2f;  ///< Π̃(l_i, l_j) above this makes l_i a merge candidate for l_j
  int confirm_confidence = 5;      ///< Ψ^m at which a merge is confirmed
  void validate () const;
};

/** \brief The pair confidences Ψ^m(l_a, l_b) of §4.2.3. Each frame every candidate pair
  * seen gains 1 and every tracked pair not seen loses 1 (floor 0, then forgotten); a pair
  * that reaches confirm_confidence is returned for merging. The thesis writes the
  * decrement as part of the same sum as the increment, which would cancel it for seen
  * pairs; this is the reading that makes the "−1 per frame unseen" of its text work.
  */
class MergeConfidence
{
public:
  explicit MergeConfidence (const SegmentMergingConfig& config = SegmentMergingConfig ());

  /** \brief One frame's candidate pairs (labels already resolved; order inside a pair and
    * duplicates do not matter). Returns the pairs confirmed by this frame, sorted.
    */
  std::vector<std::pair<std::uint32_t, std::uint32_t>>
  update (std::vector<std::pair<std::uint32_t, std::uint32_t>> seen);

  int confidence (std::uint32_t a, std::uint32_t b) const;
  std::size_t trackedPairs () const { return confidence_.size (); }

  /** \brief Re-keys tracked pairs after merges (pairs inside one segment are dropped). */
  void resolve (const LabelEquivalence& equivalence);

private:
  SegmentMergingConfig config_;
  std::map<std::pair<std::uint32_t, std::uint32_t>, int> confidence_;
};

/** \brief What the map knows of one global segment. */
struct SegmentRecord
{
  std::uint32_t id = 0;
  std::size_t first_frame = 0, last_frame = 0;
  /** Instance-cue votes: class name → (frames, summed score). The thesis discards the
    * class; it is kept here.
    */
  std::map<std::string, std::pair<int, float>> class_votes;
  std::size_t voxels = 0;                ///< from refreshStatistics
  Eigen::AlignedBox3f bounds;            ///< world frame, from refreshStatistics

  /** \brief The class with the most votes (higher summed score on a tie), "" if none. */
  std::string bestClass () const;
  /** \brief Mean score of the best class over the frames that voted for it. */
  float bestScore () const;
};

/** \brief The registry of global segments (the GSM of §4.2): label allocation, the label
  * equivalence of confirmed merges, the merge confidences, and per segment its frames,
  * class votes, voxel count and bounds.
  */
class GlobalSegmentMap
{
public:
  explicit GlobalSegmentMap (const SegmentMergingConfig& merging = SegmentMergingConfig ());

  /** \brief A fresh global label, first seen at \a frame. */
  std::uint32_t newSegment (std::size_t frame);

  /** \brief \a label was seen at \a frame, with instance-cue class info when the frame
    * segment carried one (instance ≥ 0).
    */
  void observe (std::uint32_t label, std::size_t frame, const SegmentInstance* info = nullptr);

  /** \brief Feeds one frame's merge candidates to the confidences and merges the pairs
    * confirmed; returns them (as resolved before the merge).
    */
  std::vector<std::pair<std::uint32_t, std::uint32_t>>
  updateMerges (const std::vector<std::pair<std::uint32_t, std::uint32_t>>& candidates);

  /** \brief Merges \a b into \a a now: equivalence and records only, no voxel is written. */
  std::uint32_t merge (std::uint32_t a, std::uint32_t b);

  std::uint32_t resolve (std::uint32_t label) const { return equivalence_.find (label); }
  const LabelEquivalence& equivalence () const { return equivalence_; }
  const MergeConfidence& confidences () const { return confidences_; }
  std::size_t labelsAllocated () const { return next_label_ - 1; }

  /** \brief Voxel counts and world bounds of every segment from \a volume's label layer
    * (labels resolved; voxels with no weight or no label are skipped).
    */
  void refreshStatistics (const reconstruction::TSDFVolume& volume);

  /** \brief Segments that are their own root, in increasing id. */
  std::vector<SegmentRecord> segments () const;
  const SegmentRecord* record (std::uint32_t label) const;

private:
  SegmentRecord& recordOf (std::uint32_t root);

  std::uint32_t next_label_ = 1;
  LabelEquivalence equivalence_;
  MergeConfidence confidences_;
  std::map<std::uint32_t, SegmentRecord> records_;  ///< by root label
};
}  // namespace segmentation
}  // namespace cuefusion
