// SPDX-License-Identifier: BSD-3-Clause
#include <cuefusion/io/file_io.h>
#include <cuefusion/common/exceptions.h>
#include <cuefusion/simulation/scene_renderer.h>
#include <cuefusion/simulation/simulated_detector.h>

#include <nlohmann/json.hpp>
#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cmath>
#include <map>
#include <numeric>
#include <random>
#include <set>

namespace cuefusion
{
namespace simulation
{
void
DetectorErrorConfig::validate () const
{
  auto probability = [] (double p, const char* option) {
    if (!(p >= 0.0 && p <= 1.0))
      throw ParameterError (option, "must be a probability in [0, 1]");
  };
  probability (merge_probability, "DetectorErrorConfig::merge_probability");
  probability (miss_probability, "DetectorErrorConfig::miss_probability");
  probability (split_probability, "DetectorErrorConfig::split_probability");
  if (!(false_positives >= 0.0 && false_positives <= 100.0))
    throw ParameterError ("DetectorErrorConfig::false_positives", "must lie in [0, 100] per frame");
  if (std::abs (boundary_px) > 100)
    throw ParameterError ("DetectorErrorConfig::boundary_px", "must lie in [-100, 100] pixels");
  if (boundary_jitter_px < 0 || boundary_jitter_px > 100)
    throw ParameterError ("DetectorErrorConfig::boundary_jitter_px", "must lie in [0, 100] pixels");
  if (min_pixels < 0)
    throw ParameterError ("DetectorErrorConfig::min_pixels", "must not be negative");
  if (!(min_score >= 0.0 && min_score <= max_score && max_score <= 1.0))
    throw ParameterError ("DetectorErrorConfig::min_score", "need 0 <= min <= max <= 1");
}

SimulatedDetector::SimulatedDetector (const SyntheticScene& scene, const DetectorErrorConfig& config,
                                      std::uint64_t seed)
  : scene_ (scene), detectable_ (scene.objects.size () + 1, false), config_ (config), seed_ (seed)
{
  config_.validate ();
  for (const SceneObject& o : scene_.objects)
    detectable_[o.id] = o.detectable;
}

namespace
{
/** \brief A uniform draw in [0, 1) from (seed, key): the same for the same arguments. */
double
hashedUniform (std::uint64_t seed, std::uint64_t key)
{
  return static_cast<double> (mixSeed (seed, key) >> 11) * 0x1.0p-53;
}
}  // namespace

bool
SimulatedDetector::mergesPair (std::uint16_t a, std::uint16_t b, std::size_t frame_index) const
{
  if (config_.merge_probability <= 0.0)
    return false;
  const std::uint64_t key = (static_cast<std::uint64_t> (frame_index) << 32) | (static_cast<std::uint64_t> (std::min (a, b)) << 16) | std::max (a, b);
  return hashedUniform (seed_ ^ 0x6d65726765ULL, key) < config_.merge_probability;
}

namespace
{
std::uint16_t
findRoot (std::map<std::uint16_t, std::uint16_t>& parent, std::uint16_t x)
{
  while (parent[x] != x)
    x = parent[x] = parent[parent[x]];
  return x;
}

cv::Mat
changeBoundary (const cv::Mat& mask, int px)
{
  if (px == 0)
    return mask;
  const cv::Mat kernel = cv::getStructuringElement (cv::MORPH_ELLIPSE, cv::Size (2 * std::abs (px) + 1, 2 * std::abs (px) + 1));
  cv::Mat out;
  if (px > 0)
    cv::dilate (mask, out, kernel);
  else
    cv::erode (mask, out, kernel);
  return out;
}
}  // namespace

DetectionResult
SimulatedDetector::detect (const cv::Mat& truth, std::size_t frame_index) const
{
  std::mt19937_64 rng (mixSeed (seed_, frame_index));
  std::uniform_real_distribution<double> uniform (0.0, 1.0);

  // Visible detectable objects and their pixel counts.
  std::map<std::uint16_t, int> area;
  for (int v = 0; v < truth.rows; ++v)
    for (int u = 0; u < truth.cols; ++u)
    {
      const std::uint16_t id = truth.at<std::uint16_t> (v, u);
      if (id < detectable_.size () && detectable_[id])
        ++area[id];
    }

  // Objects whose masks touch (within 2 pixels) may be merged into one detection.
  std::map<std::uint16_t, std::uint16_t> parent;
  for (const auto& [id, count] : area)
    parent[id] = id;
  if (config_.merge_probability > 0.0)
  {
    std::set<std::pair<std::uint16_t, std::uint16_t>> touching;
    for (int v = 0; v < truth.rows; ++v)
      for (int u = 0; u < truth.cols; ++u)
      {
        const std::uint16_t a = truth.at<std::uint16_t> (v, u);
        if (!area.count (a))
          continue;
        for (const auto& [du, dv] : {std::pair<int, int> (1, 0), {2, 0}, {0, 1}, {0, 2}})
        {
          if (u + du >= truth.cols || v + dv >= truth.rows)
            continue;
          const std::uint16_t b = truth.at<std::uint16_t> (v + dv, u + du);
          if (b != a && area.count (b))
            touching.insert ({std::min (a, b), std::max (a, b)});
        }
      }
    for (const auto& [a, b] : touching)
      if (mergesPair (a, b, frame_index))
        parent[findRoot (parent, a)] = findRoot (parent, b);
  }
  std::map<std::uint16_t, std::vector<std::uint16_t>> groups;
  for (const auto& [id, count] : area)
    groups[findRoot (parent, id)].push_back (id);

  struct Candidate
  {
    cv::Mat mask;
    Detection detection;
  };
  std::vector<Candidate> candidates;
  for (const auto& [root, members] : groups)
  {
    int total = 0;
    std::uint16_t largest = members.front ();
    for (std::uint16_t m : members)
    {
      total += area[m];
      if (area[m] > area[largest])
        largest = m;
    }
    // Draw every random number whatever the outcome, so one object's fate does not
    // shift the stream of the others.
    const double miss_draw = uniform (rng);
    const int jitter = config_.boundary_jitter_px > 0
                         ? std::uniform_int_distribution<int> (-config_.boundary_jitter_px, config_.boundary_jitter_px) (rng)
                         : 0;
    const double score_draw = uniform (rng);
    if (total < config_.min_pixels || miss_draw < config_.miss_probability)
      continue;
    cv::Mat mask = cv::Mat::zeros (truth.size (), CV_8U);
    for (std::uint16_t m : members)
      mask.setTo (255, truth == m);
    mask = changeBoundary (mask, config_.boundary_px + jitter);
    if (cv::countNonZero (mask) == 0)
      continue;
    const SceneObject* o = scene_.objectById (largest);
    Candidate c;
    c.mask = mask;
    c.detection.class_id = scene_.classIdOf (*o);
    c.detection.class_name = o->class_name;
    c.detection.score = static_cast<float> (config_.min_score + (config_.max_score - config_.min_score) * score_draw);
    c.detection.gt_instances = members;
    // A split: the mask cut in two by a line through its centre at a random angle, each
    // half its own detection (hashed draws: the stream above is not shifted).
    const std::uint64_t split_key = (static_cast<std::uint64_t> (frame_index) << 16) | root;
    if (config_.split_probability > 0.0 && hashedUniform (seed_ ^ 0x73706c6974ULL, split_key) < config_.split_probability)
    {
      const cv::Moments m = cv::moments (mask, true);
      const double angle = 2.0 * M_PI * hashedUniform (seed_ ^ 0x616e676c65ULL, split_key);
      const double cx = m.m10 / m.m00, cy = m.m01 / m.m00, nx = std::cos (angle), ny = std::sin (angle);
      Candidate other = c;
      // A new buffer: assigning Mat::zeros to a header would zero the buffer c shares.
      other.mask = cv::Mat (mask.size (), CV_8U, cv::Scalar (0));
      for (int v = 0; v < mask.rows; ++v)
        for (int u = 0; u < mask.cols; ++u)
          if (mask.at<std::uint8_t> (v, u) && (u - cx) * nx + (v - cy) * ny > 0.0)
          {
            other.mask.at<std::uint8_t> (v, u) = 255;
            c.mask.at<std::uint8_t> (v, u) = 0;
          }
      other.detection.score = static_cast<float> (config_.min_score + (config_.max_score - config_.min_score) *
                                                  hashedUniform (seed_ ^ 0x73636f7265ULL, split_key));
      candidates.push_back (other);
    }
    candidates.push_back (c);
  }

  // Spurious blobs of a class the scene has.
  std::vector<const SceneObject*> detectable;
  for (const SceneObject& o : scene_.objects)
    if (o.detectable)
      detectable.push_back (&o);
  const int spurious = config_.false_positives > 0.0 ? std::poisson_distribution<int> (config_.false_positives) (rng) : 0;
  for (int i = 0; i < spurious && !detectable.empty (); ++i)
  {
    const cv::Point centre (static_cast<int> (uniform (rng) * truth.cols), static_cast<int> (uniform (rng) * truth.rows));
    const cv::Size axes (std::max (2, static_cast<int> ((0.04 + 0.08 * uniform (rng)) * truth.cols)),
                         std::max (2, static_cast<int> ((0.04 + 0.08 * uniform (rng)) * truth.rows)));
    const SceneObject* o = detectable[static_cast<std::size_t> (uniform (rng) * detectable.size ()) % detectable.size ()];
    Candidate c;
    c.mask = cv::Mat::zeros (truth.size (), CV_8U);
    cv::ellipse (c.mask, centre, axes, 360.0 * uniform (rng), 0, 360, cv::Scalar (255), cv::FILLED);
    c.detection.class_id = scene_.classIdOf (*o);
    c.detection.class_name = o->class_name;
    c.detection.score = static_cast<float> (0.3 + 0.3 * uniform (rng));
    candidates.push_back (c);
  }

  // Paint by descending score; a pixel keeps the first (best) detection that claims it.
  std::stable_sort (candidates.begin (), candidates.end (),
                    [] (const Candidate& a, const Candidate& b) { return a.detection.score > b.detection.score; });
  DetectionResult result;
  result.ids = cv::Mat::zeros (truth.size (), CV_16U);
  for (Candidate& c : candidates)
  {
    const std::uint16_t id = static_cast<std::uint16_t> (result.detections.size () + 1);
    cv::Mat free_pixels = (result.ids == 0) & c.mask;
    if (cv::countNonZero (free_pixels) == 0)
      continue;
    result.ids.setTo (id, free_pixels);
    c.detection.id = id;
    result.detections.push_back (c.detection);
  }
  return result;
}

std::vector<Instance>
toInstances (const DetectionResult& result)
{
  std::vector<int> ids;
  std::vector<Instance> instances = instancesFromIdImage (result.ids, &ids);
  for (std::size_t i = 0; i < instances.size (); ++i)
    for (const Detection& d : result.detections)
      if (d.id == ids[i])
      {
        instances[i].class_id = d.class_id;
        instances[i].class_name = d.class_name;
        instances[i].score = d.score;
      }
  return instances;
}

std::string
detectionsToJson (const DetectionResult& result)
{
  nlohmann::json instances = nlohmann::json::array ();
  for (const Detection& d : result.detections)
    instances.push_back ({{"id", d.id}, {"class_id", d.class_id}, {"class_name", d.class_name}, {"score", d.score}});
  return io::jsonText (nlohmann::json ({{"instances", instances}}), 1) + "\n";
}
}  // namespace simulation
}  // namespace cuefusion
