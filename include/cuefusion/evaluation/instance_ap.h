// SPDX-License-Identifier: BSD-3-Clause
#pragma once

#include <cstddef>
#include <cstdint>
#include <map>
#include <string>
#include <vector>

namespace cuefusion
{
namespace evaluation
{
/** \brief A ground-truth instance of the evaluated cloud. */
struct TruthInstance
{
  std::string class_name;   ///< "" when the data has no classes
  /** Not an object to find (wall, floor, …): like ScanNet's void/stuff points, predictions
    * lying mostly on it are neither true nor false positives. */
  bool ignore = false;
};

/** \brief A predicted instance (a map segment). */
struct PredictedInstance
{
  std::string class_name;   ///< "" when it has no class
  double confidence = 1.0;  ///< ranks the predictions of a class
};

/** \brief Everything the AP evaluation needs, per point of the ground-truth cloud. */
struct InstanceEvaluationInput
{
  std::vector<std::uint32_t> truth;       ///< per point: instance id, 0 = void
  std::vector<std::uint32_t> predicted;   ///< per point: segment id, 0 = none
  std::map<std::uint32_t, TruthInstance> truth_instances;
  std::map<std::uint32_t, PredictedInstance> predicted_instances;  ///< segments absent here get the defaults
};

struct InstanceAPConfig
{
  std::size_t min_region_size = 100;   ///< points; smaller instances (truth and predicted) are skipped, as in ScanNet
  void validate () const;
};

/** \brief AP averaged over IoU thresholds 0.50, 0.55, …, 0.90 (ScanNet: np.arange(0.5, 0.95, 0.05)), AP at 0.5 and at 0.25 (NaN where undefined: no
  * ground truth of that class). */
struct APScores
{
  double ap = 0.0;
  double ap50 = 0.0;
  double ap25 = 0.0;
};

/** \brief How the predicted segments cover the truth, stuff (ignored instances) included:
  * each predicted segment of ≥ min_region_size points counts for the truth instance holding
  * most of its points.
  */
struct SegmentationCounts
{
  std::size_t truth = 0;             ///< truth instances of ≥ min_region_size points, stuff included
  std::size_t segments = 0;          ///< predicted segments of ≥ min_region_size points
  std::size_t over_segmented = 0;    ///< truth instances with two or more segments counting for them
  std::size_t extra_segments = 0;    ///< segments beyond the first of each truth instance
  /** Segments of which a second truth instance (not the majority one) holds at least a
    * quarter of the points: two objects (or an object and the table) in one segment. */
  std::size_t under_segmented = 0;
};

/** \brief The ranked detections of one class at one IoU threshold: what ScanNet's
  * evaluate_matches accumulates scene after scene before it computes one AP. Lists of
  * several scenes pool by concatenation (poolMatches), which is how the benchmark's
  * dataset-level AP is defined; a mean of per-scene APs is a different number.
  */
struct ThresholdMatches
{
  double threshold = 0.5;
  std::size_t truths = 0;        ///< evaluated truth instances (AP is NaN without any)
  std::size_t predictions = 0;   ///< evaluated predictions (AP is 0 without any)
  std::size_t missed = 0;        ///< truth instances no prediction matched (hard false negatives)
  std::vector<double> scores;    ///< one per true or false positive, unordered
  std::vector<bool> true_positive;
};

/** \brief Matches at the thresholds of matchThresholds(), class-agnostic and per class. */
struct InstanceMatches
{
  std::vector<ThresholdMatches> class_agnostic;
  /** Classes of the truth and of the predictions: a scene's predictions of a class it has
    * no truth of are false positives once pooled with scenes that have. */
  std::map<std::string, std::vector<ThresholdMatches>> per_class;
};

struct InstanceAPResult
{
  APScores class_agnostic;                 ///< every instance as one class "object"
  std::map<std::string, APScores> per_class;  ///< classes of the ground truth (empty without classes)
  APScores class_mean;                     ///< NaN-ignoring mean over per_class (NaN without classes)
  std::size_t truth_instances = 0;         ///< evaluated (not ignored, ≥ min_region_size)
  std::size_t predicted_instances = 0;     ///< ≥ min_region_size points
  SegmentationCounts counts;
  InstanceMatches matches;                 ///< for pooling with other scenes (pooledInstanceAP)
};

/** \brief 3D instance segmentation AP with the ScanNet benchmark's definition
  * (evaluate_semantic_instance.py): per class, predictions ranked by confidence, a
  * prediction is a true positive for the first ground-truth instance it overlaps with
  * IoU > threshold that no higher-ranked prediction took (a second one is a false
  * positive), unmatched predictions are false positives unless more than the threshold
  * of their points lie on void/ignored truth, and AP integrates the precision–recall
  * curve by its trapezoid-on-steps rule. Throws cuefusion::Error when the two label
  * vectors differ in length.
  */
InstanceAPResult
evaluateInstanceAP (const InstanceEvaluationInput& input, const InstanceAPConfig& config = InstanceAPConfig ());

/** \brief The IoU thresholds AP averages: 0.50, 0.55, …, 0.90 (9 values, as ScanNet). */
std::vector<double>
apThresholds ();

/** \brief Mean of the values that are not NaN (numpy's nanmean); NaN when there are none. */
double
nanMean (const std::vector<double>& values);

/** \brief The thresholds InstanceMatches lists: apThresholds(), then 0.25. */
std::vector<double>
matchThresholds ();

/** \brief ScanNet's average precision of ranked detections: NaN without truth, 0 without
  * predictions, else the precision–recall curve at every distinct score integrated by the
  * benchmark's step rule. */
double
averagePrecision (const ThresholdMatches& matches);

/** \brief AP, AP50 and AP25 of one class from its matches at matchThresholds(). Throws
  * cuefusion::Error when the list does not hold those thresholds. */
APScores
apFromMatches (const std::vector<ThresholdMatches>& matches);

/** \brief Appends \a scene's matches to \a pooled (same threshold; the counts add up).
  * Throws cuefusion::Error when the thresholds differ. */
void
poolMatches (ThresholdMatches& pooled, const ThresholdMatches& scene);

/** \brief Dataset-level AP the way the ScanNet benchmark computes it: each class's
  * matches pooled over all scenes per threshold, then one AP per class and threshold
  * (class_mean: NaN-ignoring mean over the classes with truth). Fills class_agnostic,
  * per_class, class_mean, the instance counts and matches; not counts. */
InstanceAPResult
pooledInstanceAP (const std::vector<InstanceMatches>& scenes);
}  // namespace evaluation
}  // namespace cuefusion
