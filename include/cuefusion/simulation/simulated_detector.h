// SPDX-License-Identifier: BSD-3-Clause
#pragma once

#include <cuefusion/common/instance.h>
#include <cuefusion/simulation/synthetic_scene.h>

#include <opencv2/core.hpp>

#include <cstdint>
#include <string>
#include <vector>

namespace cuefusion
{
namespace simulation
{
/** \brief Errors a simulated instance-segmentation network makes, all seeded.
  * With the defaults it is a perfect detector of every detectable object.
  */
struct DetectorErrorConfig
{
  int boundary_px = 0;              ///< > 0 grows ("leaking" masks, thesis §5.3.2.2), < 0 shrinks masks
  int boundary_jitter_px = 0;       ///< extra per-mask, per-frame change in [−j, j] pixels
  double merge_probability = 0.0;   ///< chance, per pair of touching objects and frame, that they are reported as one mask (Fig. 5.19)
  double split_probability = 0.0;   ///< chance, per reported mask and frame, that it comes as two masks (cut by a random line through its centre)
  double miss_probability = 0.0;    ///< chance, per object and frame, that an object is not reported
  double false_positives = 0.0;     ///< mean number of spurious masks per frame (Poisson)
  int min_pixels = 50;              ///< objects with fewer visible pixels are never reported
  double min_score = 0.7;           ///< scores of true detections are uniform in [min, max]
  double max_score = 0.99;

  /** \brief Throws cuefusion::Error naming the option for values outside their range. */
  void validate () const;
};

/** \brief One reported instance. */
struct Detection
{
  std::uint16_t id = 0;                     ///< value in DetectionResult::ids (1-based)
  std::uint16_t class_id = 0;               ///< SyntheticScene class id
  std::string class_name;
  float score = 0.f;
  std::vector<std::uint16_t> gt_instances;  ///< true objects it covers (empty for a false positive)
};

/** \brief Output of a detector on one frame: an instance-id image and the detections. */
struct DetectionResult
{
  cv::Mat ids;   ///< CV_16U, 0 = no detection; overlaps go to the higher score
  std::vector<Detection> detections;
};

/** \brief Turns exact instance masks into the masks a network would give, with the errors
  * of DetectorErrorConfig. Every error is drawn per frame, from streams seeded by (seed,
  * frame) — merges and splits by (seed, pair or object, frame) — so a frame's masks do not
  * depend on which frames were made before it. Merges are per frame because that is how
  * real networks fail on touching objects: in some views, not in all (a network that
  * merged a pair in every view would be indistinguishable from one object).
  */
class SimulatedDetector
{
public:
  SimulatedDetector (const SyntheticScene& scene, const DetectorErrorConfig& config, std::uint64_t seed);

  DetectionResult detect (const cv::Mat& instance_truth, std::size_t frame_index) const;

  /** \brief Whether objects a and b are reported as one in frame \a frame_index when they touch. */
  bool mergesPair (std::uint16_t a, std::uint16_t b, std::size_t frame_index) const;

private:
  SyntheticScene scene_;  // a copy: small, and no lifetime ties to the caller
  std::vector<bool> detectable_;   ///< by object id (index 0 unused)
  DetectorErrorConfig config_;
  std::uint64_t seed_;
};

/** \brief The detections as instance masks (in id order), with class names and scores. */
std::vector<Instance>
toInstances (const DetectionResult& result);

/** \brief The per-frame JSON written next to a detection PNG:
  * {"instances": [{"id", "class_id", "class_name", "score"}, …]}.
  */
std::string
detectionsToJson (const DetectionResult& result);
}  // namespace simulation
}  // namespace cuefusion
