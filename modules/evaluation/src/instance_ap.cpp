// SPDX-License-Identifier: BSD-3-Clause
#include <cuefusion/common/exceptions.h>
#include <cuefusion/evaluation/instance_ap.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <numeric>
#include <set>
#include <unordered_map>

namespace cuefusion
{
namespace evaluation
{
void
InstanceAPConfig::validate () const
{
  if (min_region_size == 0)
    throw ParameterError ("InstanceAPConfig::min_region_size", "must be at least 1");
}

std::vector<double>
apThresholds ()
{
  std::vector<double> t;
  for (int i = 0; i < 9; ++i)
    t.push_back (0.5 + 0.05 * i);
  return t;
}

namespace
{
const double kNaN = std::numeric_limits<double>::quiet_NaN ();

/** Point counts the matching needs, gathered in one pass over the cloud. */
struct Overlaps
{
  std::unordered_map<std::uint32_t, std::size_t> truth_size, pred_size;
  std::unordered_map<std::uint32_t, std::unordered_map<std::uint32_t, std::size_t>> pred_truth;  ///< pred → truth → points
  std::unordered_map<std::uint32_t, std::size_t> pred_void;  ///< points on truth id 0
};

/** The ranked detections of one class at one IoU threshold, as ScanNet's evaluate_matches
  * gathers them for one scene. */
ThresholdMatches
collectMatches (const std::vector<std::uint32_t>& truths, const std::vector<std::uint32_t>& preds, const Overlaps& o,
                const InstanceEvaluationInput& input, std::size_t min_region_size,
                const std::set<std::uint32_t>& same_class_truth, double threshold)
{
  ThresholdMatches m;
  m.threshold = threshold;
  m.truths = truths.size ();
  m.predictions = preds.size ();
  const auto confidence = [&] (std::uint32_t p) {
    const auto it = input.predicted_instances.find (p);
    return it == input.predicted_instances.end () ? 1.0 : it->second.confidence;
  };
  const auto iouOf = [&] (std::uint32_t t, std::uint32_t p) {
    const auto& row = o.pred_truth.at (p);
    const auto it = row.find (t);
    if (it == row.end ())
      return 0.0;
    const double inter = static_cast<double> (it->second);
    return inter / (static_cast<double> (o.truth_size.at (t) + o.pred_size.at (p)) - inter);
  };
  const auto add = [&m] (double score, bool true_positive) {
    m.scores.push_back (score);
    m.true_positive.push_back (true_positive);
  };
  // ScanNet walks each ground-truth instance's overlapping predictions in the order the
  // predictions were listed; ours are listed by id (deterministic).
  std::set<std::uint32_t> visited;
  for (const std::uint32_t t : truths)
  {
    bool matched = false;
    double score = -std::numeric_limits<double>::infinity ();
    for (const std::uint32_t p : preds)
    {
      if (visited.count (p) || iouOf (t, p) <= threshold)
        continue;
      const double c = confidence (p);
      if (matched)
      {
        // A second prediction above the threshold: the lower-ranked one is a false positive.
        add (std::min (score, c), false);
        score = std::max (score, c);
      }
      else
      {
        matched = true;
        score = c;
        visited.insert (p);
      }
    }
    if (matched)
      add (score, true);
    else
      ++m.missed;
  }
  for (const std::uint32_t p : preds)
  {
    bool found = false;
    std::size_t ignored = o.pred_void.count (p) ? o.pred_void.at (p) : 0;
    for (const auto& [t, inter] : o.pred_truth.at (p))
    {
      const auto info = input.truth_instances.find (t);
      if (info != input.truth_instances.end () && info->second.ignore)
      {
        ignored += inter;  // void for every class, like ScanNet's unevaluated classes
        continue;
      }
      if (!same_class_truth.count (t))
        continue;  // another class's object: overlapping it is a plain false positive
      if (iouOf (t, p) > threshold)
      {
        found = true;
        break;
      }
      if (o.truth_size.at (t) < min_region_size)
        ignored += inter;
    }
    if (found)
      continue;
    if (static_cast<double> (ignored) / static_cast<double> (o.pred_size.at (p)) <= threshold)
      add (confidence (p), false);
  }
  return m;
}

std::vector<ThresholdMatches>
matchesFor (const std::vector<std::uint32_t>& truths, const std::vector<std::uint32_t>& preds, const Overlaps& o,
            const InstanceEvaluationInput& input, std::size_t min_region_size, const std::set<std::uint32_t>& same_class_truth)
{
  std::vector<ThresholdMatches> matches;
  for (const double t : matchThresholds ())
    matches.push_back (collectMatches (truths, preds, o, input, min_region_size, same_class_truth, t));
  return matches;
}
}  // namespace

double
nanMean (const std::vector<double>& values)
{
  double sum = 0.0;
  std::size_t n = 0;
  for (const double v : values)
    if (!std::isnan (v))
    {
      sum += v;
      ++n;
    }
  return n ? sum / static_cast<double> (n) : kNaN;
}

std::vector<double>
matchThresholds ()
{
  std::vector<double> t = apThresholds ();
  t.push_back (0.25);
  return t;
}

double
averagePrecision (const ThresholdMatches& m)
{
  if (m.truths == 0)
    return kNaN;
  if (m.predictions == 0)
    return 0.0;
  if (m.scores.size () != m.true_positive.size ())
    throw Error ("averagePrecision", "scores and true_positive differ in length");
  // Precision/recall at every distinct score, then ScanNet's step integration.
  std::vector<std::size_t> order (m.scores.size ());
  std::iota (order.begin (), order.end (), 0);
  std::stable_sort (order.begin (), order.end (), [&] (std::size_t a, std::size_t b) { return m.scores[a] < m.scores[b]; });
  std::vector<double> cumsum (order.size ());
  double running = 0.0;
  for (std::size_t i = 0; i < order.size (); ++i)
    cumsum[i] = running += m.true_positive[order[i]] ? 1.0 : 0.0;
  const double total_true = running;
  const double examples = static_cast<double> (order.size ());
  std::vector<double> precision, recall;
  for (std::size_t i = 0; i < order.size (); ++i)
  {
    if (i > 0 && m.scores[order[i]] == m.scores[order[i - 1]])
      continue;  // first index of each distinct score, as np.unique(return_index=True)
    const double below = i > 0 ? cumsum[i - 1] : 0.0;
    const double tp = total_true - below;
    const double fp = examples - static_cast<double> (i) - tp;
    const double fn = below + static_cast<double> (m.missed);
    precision.push_back (tp + fp > 0.0 ? tp / (tp + fp) : 0.0);
    recall.push_back (tp + fn > 0.0 ? tp / (tp + fn) : 0.0);
  }
  precision.push_back (1.0);
  recall.push_back (0.0);
  // step widths: np.convolve([r0, r0, r1, …, r_last, 0], [-0.5, 0, 0.5], 'valid')
  std::vector<double> padded;
  padded.push_back (recall.front ());
  padded.insert (padded.end (), recall.begin (), recall.end ());
  padded.push_back (0.0);
  double ap = 0.0;
  for (std::size_t k = 0; k < precision.size (); ++k)
    ap += precision[k] * 0.5 * (padded[k] - padded[k + 2]);
  return ap;
}

APScores
apFromMatches (const std::vector<ThresholdMatches>& matches)
{
  const std::vector<double> thresholds = matchThresholds ();
  if (matches.size () != thresholds.size ())
    throw Error ("apFromMatches", "expected matches at " + std::to_string (thresholds.size ()) + " thresholds, got " +
                                      std::to_string (matches.size ()));
  std::vector<double> aps;
  for (std::size_t k = 0; k < matches.size (); ++k)
  {
    if (std::abs (matches[k].threshold - thresholds[k]) > 1e-9)
      throw Error ("apFromMatches", "matches are not at the thresholds of matchThresholds()");
    if (k + 1 < matches.size ())
      aps.push_back (averagePrecision (matches[k]));
  }
  APScores s;
  s.ap = nanMean (aps);
  s.ap50 = aps.front ();
  s.ap25 = averagePrecision (matches.back ());
  return s;
}

void
poolMatches (ThresholdMatches& pooled, const ThresholdMatches& scene)
{
  if (std::abs (pooled.threshold - scene.threshold) > 1e-9)
    throw Error ("poolMatches", "cannot pool matches at IoU " + std::to_string (scene.threshold) + " into matches at " +
                                    std::to_string (pooled.threshold));
  if (scene.scores.size () != scene.true_positive.size ())
    throw Error ("poolMatches", "scores and true_positive differ in length");
  pooled.truths += scene.truths;
  pooled.predictions += scene.predictions;
  pooled.missed += scene.missed;
  pooled.scores.insert (pooled.scores.end (), scene.scores.begin (), scene.scores.end ());
  pooled.true_positive.insert (pooled.true_positive.end (), scene.true_positive.begin (), scene.true_positive.end ());
}

InstanceAPResult
pooledInstanceAP (const std::vector<InstanceMatches>& scenes)
{
  const auto empty = [] {
    std::vector<ThresholdMatches> m;
    for (const double t : matchThresholds ())
    {
      m.emplace_back ();
      m.back ().threshold = t;
    }
    return m;
  };
  const auto pool = [] (std::vector<ThresholdMatches>& into, const std::vector<ThresholdMatches>& scene) {
    if (scene.size () != into.size ())
      throw Error ("pooledInstanceAP", "a scene lists matches at " + std::to_string (scene.size ()) + " thresholds, not " +
                                           std::to_string (into.size ()));
    for (std::size_t k = 0; k < into.size (); ++k)
      poolMatches (into[k], scene[k]);
  };
  InstanceAPResult result;
  result.matches.class_agnostic = empty ();
  for (const InstanceMatches& scene : scenes)
  {
    pool (result.matches.class_agnostic, scene.class_agnostic);
    for (const auto& [name, matches] : scene.per_class)
    {
      auto it = result.matches.per_class.find (name);
      if (it == result.matches.per_class.end ())
        it = result.matches.per_class.emplace (name, empty ()).first;
      pool (it->second, matches);
    }
  }
  result.class_agnostic = apFromMatches (result.matches.class_agnostic);
  result.truth_instances = result.matches.class_agnostic.front ().truths;
  result.predicted_instances = result.matches.class_agnostic.front ().predictions;
  std::vector<double> ap, ap50, ap25;
  for (const auto& [name, matches] : result.matches.per_class)
  {
    if (matches.front ().truths == 0)
      continue;  // predicted only: its false positives are in, but it is not a class of the truth
    const APScores s = apFromMatches (matches);
    result.per_class[name] = s;
    ap.push_back (s.ap);
    ap50.push_back (s.ap50);
    ap25.push_back (s.ap25);
  }
  result.class_mean = {nanMean (ap), nanMean (ap50), nanMean (ap25)};
  return result;
}

InstanceAPResult
evaluateInstanceAP (const InstanceEvaluationInput& input, const InstanceAPConfig& config)
{
  config.validate ();
  if (input.truth.size () != input.predicted.size ())
    throw Error ("evaluateInstanceAP", "ground truth has " + std::to_string (input.truth.size ()) + " points, the prediction " +
                                           std::to_string (input.predicted.size ()));
  Overlaps o;
  for (std::size_t i = 0; i < input.truth.size (); ++i)
  {
    const std::uint32_t t = input.truth[i], p = input.predicted[i];
    if (t)
      ++o.truth_size[t];
    if (!p)
      continue;
    ++o.pred_size[p];
    o.pred_truth[p];  // every prediction gets a row
    if (t)
      ++o.pred_truth[p][t];
    else
      ++o.pred_void[p];
  }
  const auto truthInfo = [&] (std::uint32_t t) {
    const auto it = input.truth_instances.find (t);
    return it == input.truth_instances.end () ? TruthInstance () : it->second;
  };
  const auto predInfo = [&] (std::uint32_t p) {
    const auto it = input.predicted_instances.find (p);
    return it == input.predicted_instances.end () ? PredictedInstance () : it->second;
  };

  std::vector<std::uint32_t> truths, preds;
  std::set<std::uint32_t> all_truth;
  std::set<std::string> classes;
  for (const auto& [t, n] : o.truth_size)
  {
    const TruthInstance info = truthInfo (t);
    if (info.ignore || n < config.min_region_size)
      continue;
    truths.push_back (t);
    all_truth.insert (t);
    if (!info.class_name.empty ())
      classes.insert (info.class_name);
  }
  for (const auto& [p, n] : o.pred_size)
    if (n >= config.min_region_size)
      preds.push_back (p);
  std::sort (truths.begin (), truths.end ());
  std::sort (preds.begin (), preds.end ());

  InstanceAPResult result;
  result.truth_instances = truths.size ();
  result.predicted_instances = preds.size ();
  // Class-agnostic: every non-ignored instance is an "object", so truth points of other
  // objects are not void for it.
  std::set<std::uint32_t> any_truth;
  for (const auto& [t, n] : o.truth_size)
    any_truth.insert (t);
  result.matches.class_agnostic = matchesFor (truths, preds, o, input, config.min_region_size, any_truth);
  result.class_agnostic = apFromMatches (result.matches.class_agnostic);

  std::vector<double> ap, ap50, ap25;
  std::set<std::string> predicted_classes;
  for (const std::uint32_t p : preds)
    if (!predInfo (p).class_name.empty ())
      predicted_classes.insert (predInfo (p).class_name);
  for (const std::string& c : predicted_classes)
    if (!classes.count (c))
    {
      // No truth of this class here: its predictions are only false positives, kept
      // for pooling with scenes that have the class (it gets no AP of its own).
      std::vector<std::uint32_t> class_preds;
      for (const std::uint32_t p : preds)
        if (predInfo (p).class_name == c)
          class_preds.push_back (p);
      result.matches.per_class[c] = matchesFor ({}, class_preds, o, input, config.min_region_size, {});
    }
  for (const std::string& c : classes)
  {
    std::vector<std::uint32_t> class_truths, class_preds;
    std::set<std::uint32_t> same_class;
    for (const auto& [t, n] : o.truth_size)
      if (truthInfo (t).class_name == c)
        same_class.insert (t);
    for (const std::uint32_t t : truths)
      if (same_class.count (t))
        class_truths.push_back (t);
    for (const std::uint32_t p : preds)
      if (predInfo (p).class_name == c)
        class_preds.push_back (p);
    result.matches.per_class[c] = matchesFor (class_truths, class_preds, o, input, config.min_region_size, same_class);
    const APScores s = apFromMatches (result.matches.per_class[c]);
    result.per_class[c] = s;
    ap.push_back (s.ap);
    ap50.push_back (s.ap50);
    ap25.push_back (s.ap25);
  }
  result.class_mean = {nanMean (ap), nanMean (ap50), nanMean (ap25)};

  SegmentationCounts& counts = result.counts;
  for (const auto& [t, n] : o.truth_size)
    counts.truth += n >= config.min_region_size ? 1 : 0;
  std::map<std::uint32_t, std::size_t> segments_of;  // truth → segments counting for it
  for (const std::uint32_t p : preds)
  {
    ++counts.segments;
    std::uint32_t majority = 0;
    std::size_t most = 0, second = 0;
    for (const auto& [t, inter] : o.pred_truth.at (p))
      if (inter > most)
      {
        second = most;
        most = inter;
        majority = t;
      }
      else
        second = std::max (second, inter);
    if (majority)
      ++segments_of[majority];
    if (4 * second >= o.pred_size.at (p))
      ++counts.under_segmented;
  }
  for (const auto& [t, n] : segments_of)
  {
    counts.over_segmented += n >= 2 ? 1 : 0;
    counts.extra_segments += n - 1;
  }
  return result;
}
}  // namespace evaluation
}  // namespace cuefusion
