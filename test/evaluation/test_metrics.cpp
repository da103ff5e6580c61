// SPDX-License-Identifier: BSD-3-Clause
// Evaluation metrics against hand-built cases whose answers are derived analytically.
#include <cuefusion/common/exceptions.h>
#include <cuefusion/evaluation/instance_ap.h>
#include <cuefusion/evaluation/object_iou.h>
#include <cuefusion/evaluation/trajectory_error.h>

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <numeric>
#include <random>

using namespace cuefusion;
using namespace cuefusion::evaluation;

namespace
{
Eigen::Isometry3d
pose (double x, double y, double z, double yaw)
{
  Eigen::Isometry3d p = Eigen::Isometry3d::Identity ();
  p.linear () = Eigen::AngleAxisd (yaw, Eigen::Vector3d::UnitZ ()).toRotationMatrix ();
  p.translation () = Eigen::Vector3d (x, y, z);
  return p;
}
}  // namespace

TEST (TrajectoryError, AlternatingOffsetGivesItsSizeAfterAlignment)
{
  // Every reference position is visited twice; the estimate is the reference moved by a
  // rigid G plus ±d along z on the two visits. The offsets have zero mean and zero
  // correlation with the positions, so the best alignment is exactly G⁻¹ and ATE = d.
  const double d = 0.013;
  Eigen::Isometry3d g = pose (0.4, -1.2, 0.3, 0.7);
  g.linear () = (Eigen::AngleAxisd (0.2, Eigen::Vector3d::UnitX ()) * Eigen::AngleAxisd (0.7, Eigen::Vector3d::UnitZ ())).toRotationMatrix ();
  io::Trajectory reference, estimate;
  for (int k = 0; k < 40; ++k)
  {
    const double a = 0.15 * k;
    const Eigen::Isometry3d q = pose (1.5 * std::cos (a), 1.5 * std::sin (a), 0.2 * std::sin (3 * a), a);
    for (int visit = 0; visit < 2; ++visit)
    {
      const double t = 0.1 * (2 * k + visit);
      reference.push_back ({t, q});
      Eigen::Isometry3d p = q;
      p.translation ().z () += visit ? d : -d;
      estimate.push_back ({t, g * p});
    }
  }
  const TrajectoryError ate = absoluteTrajectoryError (estimate, reference);
  EXPECT_EQ (ate.pairs, 80u);
  EXPECT_NEAR (ate.rmse, d, 1e-9);
  EXPECT_NEAR (ate.mean, d, 1e-9);
  EXPECT_NEAR (ate.max, d, 1e-9);
  EXPECT_TRUE (ate.alignment.isApprox (g.inverse (), 1e-9));
  // Without alignment the error is the distance G moves each point.
  const TrajectoryError raw = absoluteTrajectoryError (estimate, reference, 0.02, false);
  EXPECT_GT (raw.rmse, 0.5);
}

TEST (TrajectoryError, RelativePoseErrorOfConstantDrift)
{
  // The estimate moves δ further along its own x axis every frame than the reference.
  // RPE over one frame is exactly δ; with a reference that only translates (no rotation)
  // the error over 1 s (10 frames at 10 Hz) is exactly 10 δ.
  const double delta = 0.004;
  for (const bool rotating : {true, false})
  {
    io::Trajectory reference, estimate;
    Eigen::Isometry3d p = Eigen::Isometry3d::Identity ();
    for (int i = 0; i < 50; ++i)
    {
      const Eigen::Isometry3d q = pose (0.02 * i, 0.01 * i, 0.0, rotating ? 0.03 * i : 0.0);
      if (i > 0)
      {
        const Eigen::Isometry3d motion = reference.back ().pose.inverse () * q;
        Eigen::Isometry3d drift = Eigen::Isometry3d::Identity ();
        drift.translation ().x () = delta;
        p = p * motion * drift;
      }
      else
        p = q;
      reference.push_back ({0.1 * i, q});
      estimate.push_back ({0.1 * i, p});
    }
    const RelativePoseError frame = relativePoseError (estimate, reference, {RelativePoseInterval::Unit::Frames, 1.0});
    EXPECT_EQ (frame.pairs, 49u);
    EXPECT_NEAR (frame.translation_rmse, delta, 1e-9);
    EXPECT_NEAR (frame.rotation_rmse_deg, 0.0, 1e-6);
    if (!rotating)
    {
      const RelativePoseError second = relativePoseError (estimate, reference, {RelativePoseInterval::Unit::Seconds, 1.0});
      EXPECT_EQ (second.pairs, 40u);
      EXPECT_NEAR (second.translation_rmse, 10 * delta, 1e-9);
    }
  }
  io::Trajectory two = {{0.0, Eigen::Isometry3d::Identity ()}, {0.1, Eigen::Isometry3d::Identity ()}};
  EXPECT_THROW (relativePoseError (two, two, {RelativePoseInterval::Unit::Seconds, 1.0}), Error);
}

TEST (Assignment, MatchesBruteForceOnRandomMatrices)
{
  std::mt19937 rng (7);
  std::uniform_real_distribution<double> uniform (0.0, 1.0);
  for (int trial = 0; trial < 60; ++trial)
  {
    const int rows = 1 + trial % 5, cols = 1 + (trial / 5) % 5;
    Eigen::MatrixXd w (rows, cols);
    for (int r = 0; r < rows; ++r)
      for (int c = 0; c < cols; ++c)
        w (r, c) = uniform (rng) < 0.3 ? 0.0 : uniform (rng);
    const std::vector<int> match = maximumWeightAssignment (w);
    double total = 0.0;
    std::vector<int> used;
    for (int r = 0; r < rows; ++r)
      if (match[static_cast<std::size_t> (r)] >= 0)
      {
        total += w (r, match[static_cast<std::size_t> (r)]);
        used.push_back (match[static_cast<std::size_t> (r)]);
      }
    std::sort (used.begin (), used.end ());
    EXPECT_EQ (std::adjacent_find (used.begin (), used.end ()), used.end ()) << "a column used twice";
    // Brute force over injective maps of the smaller side.
    double best = 0.0;
    std::vector<int> perm (static_cast<std::size_t> (std::max (rows, cols)));
    std::iota (perm.begin (), perm.end (), 0);
    do
    {
      double sum = 0.0;
      for (int r = 0; r < rows; ++r)
        if (perm[static_cast<std::size_t> (r)] < cols)
          sum += w (r, perm[static_cast<std::size_t> (r)]);
      best = std::max (best, sum);
    } while (std::next_permutation (perm.begin (), perm.end ()));
    EXPECT_NEAR (total, best, 1e-12) << w;
  }
}

namespace
{
/** 40×40 truth with two 10×20 objects: 1 (rows 0–9) and 2 (rows 20–29), columns 0–19. */
cv::Mat
twoObjects ()
{
  cv::Mat truth = cv::Mat::zeros (40, 40, CV_16U);
  truth (cv::Rect (0, 0, 20, 10)).setTo (1);
  truth (cv::Rect (0, 20, 20, 10)).setTo (2);
  return truth;
}

const ObjectIoU&
objectOf (const std::vector<ObjectIoU>& scores, std::uint32_t id)
{
  for (const ObjectIoU& o : scores)
    if (o.instance == id)
      return o;
  throw std::runtime_error ("object not scored");
}
}  // namespace

TEST (FrameObjectIoU, HandBuiltCases)
{
  const cv::Mat truth = twoObjects ();
  FrameIoUConfig config;
  config.min_truth_pixels = 10;
  // Perfect, with different ids.
  cv::Mat predicted = cv::Mat::zeros (40, 40, CV_32S);
  predicted (cv::Rect (0, 0, 20, 10)).setTo (7);
  predicted (cv::Rect (0, 20, 20, 10)).setTo (3);
  auto scores = frameObjectIoU (predicted, truth, cv::Mat (), config);
  ASSERT_EQ (scores.size (), 2u);
  EXPECT_DOUBLE_EQ (objectOf (scores, 1).iou, 1.0);
  EXPECT_EQ (objectOf (scores, 1).segment, 7);
  EXPECT_DOUBLE_EQ (objectOf (scores, 2).iou, 1.0);

  // Object 1 split in two halves: its best match covers half of it.
  predicted (cv::Rect (10, 0, 10, 10)).setTo (8);
  scores = frameObjectIoU (predicted, truth, cv::Mat (), config);
  EXPECT_DOUBLE_EQ (objectOf (scores, 1).iou, 0.5);
  EXPECT_DOUBLE_EQ (objectOf (scores, 2).iou, 1.0);

  // One segment over both objects: one of them gets it (IoU 200 / 400), the other nothing.
  predicted.setTo (0);
  predicted (cv::Rect (0, 0, 20, 10)).setTo (5);
  predicted (cv::Rect (0, 20, 20, 10)).setTo (5);
  scores = frameObjectIoU (predicted, truth, cv::Mat (), config);
  EXPECT_DOUBLE_EQ (objectOf (scores, 1).iou + objectOf (scores, 2).iou, 0.5);

  // Object 2 missed.
  predicted.setTo (0);
  predicted (cv::Rect (0, 0, 20, 10)).setTo (5);
  scores = frameObjectIoU (predicted, truth, cv::Mat (), config);
  EXPECT_DOUBLE_EQ (objectOf (scores, 1).iou, 1.0);
  EXPECT_DOUBLE_EQ (objectOf (scores, 2).iou, 0.0);
  EXPECT_EQ (objectOf (scores, 2).segment, 0);

  // Hungarian, not greedy: segment 9 overlaps object 1 most, but giving it to object 2
  // and segment 4 to object 1 sums higher.
  predicted.setTo (0);
  predicted (cv::Rect (0, 0, 20, 10)).setTo (9);
  predicted (cv::Rect (0, 10, 20, 20)).setTo (9);  // 9 also covers object 2 and the gap
  predicted (cv::Rect (0, 0, 10, 10)).setTo (4);   // 4 = left half of object 1
  scores = frameObjectIoU (predicted, truth, cv::Mat (), config);
  EXPECT_EQ (objectOf (scores, 1).segment, 4);
  EXPECT_EQ (objectOf (scores, 2).segment, 9);
  EXPECT_DOUBLE_EQ (objectOf (scores, 1).iou, 0.5);
  EXPECT_DOUBLE_EQ (objectOf (scores, 2).iou, 200.0 / 500.0);

  // Pixels outside the valid mask do not count; too-small objects are not scored.
  cv::Mat valid = cv::Mat::zeros (40, 40, CV_8U);
  valid (cv::Rect (0, 0, 40, 15)).setTo (255);
  scores = frameObjectIoU (predicted, truth, valid, config);
  ASSERT_EQ (scores.size (), 1u);
  EXPECT_EQ (scores[0].instance, 1u);

  const SequenceIoU summary = summarizeObjectIoU ({{{1, 4, 0, 0, 0, 1.0}, {2, 9, 0, 0, 0, 0.5}}, {{1, 4, 0, 0, 0, 0.5}}});
  EXPECT_DOUBLE_EQ (summary.object_mean.at (1), 0.75);
  EXPECT_DOUBLE_EQ (summary.mean, 0.625);
  EXPECT_THROW (frameObjectIoU (cv::Mat::zeros (5, 5, CV_32S), truth), Error);
  EXPECT_THROW (frameObjectIoU (cv::Mat::zeros (40, 40, CV_8U), truth), Error);
}

namespace
{
/** Two 200-point objects (ids 1, 2) and 100 void points; the prediction fills in per case. */
InstanceEvaluationInput
twoInstances ()
{
  InstanceEvaluationInput in;
  for (int i = 0; i < 500; ++i)
    in.truth.push_back (i < 200 ? 1u : (i < 400 ? 2u : 0u));
  in.predicted.assign (500, 0);
  return in;
}

void
predict (InstanceEvaluationInput& in, int begin, int end, std::uint32_t label)
{
  for (int i = begin; i < end; ++i)
    in.predicted[static_cast<std::size_t> (i)] = label;
}
}  // namespace

TEST (InstanceAP, HandBuiltCases)
{
  // Perfect.
  InstanceEvaluationInput in = twoInstances ();
  predict (in, 0, 200, 11);
  predict (in, 200, 400, 12);
  InstanceAPResult r = evaluateInstanceAP (in);
  EXPECT_EQ (r.truth_instances, 2u);
  EXPECT_DOUBLE_EQ (r.class_agnostic.ap, 1.0);
  EXPECT_DOUBLE_EQ (r.class_agnostic.ap50, 1.0);
  EXPECT_DOUBLE_EQ (r.class_agnostic.ap25, 1.0);
  EXPECT_TRUE (r.per_class.empty ());
  EXPECT_TRUE (std::isnan (r.class_mean.ap));

  // An extra prediction lying on void points is ignored, not a false positive.
  predict (in, 400, 500, 13);
  EXPECT_DOUBLE_EQ (evaluateInstanceAP (in).class_agnostic.ap, 1.0);

  // One object missed: precision 1 up to recall 0.5 → AP = 0.5 at every threshold.
  in = twoInstances ();
  predict (in, 0, 200, 11);
  r = evaluateInstanceAP (in);
  EXPECT_DOUBLE_EQ (r.class_agnostic.ap, 0.5);
  EXPECT_DOUBLE_EQ (r.class_agnostic.ap25, 0.5);

  // One merged pair: IoU 0.5 is not > 0.5, so nothing matches from 0.5 up (AP 0); at 0.25
  // the segment finds one object → as the missed case, 0.5.
  in = twoInstances ();
  predict (in, 0, 400, 11);
  r = evaluateInstanceAP (in);
  EXPECT_DOUBLE_EQ (r.class_agnostic.ap50, 0.0);
  EXPECT_DOUBLE_EQ (r.class_agnostic.ap, 0.0);
  EXPECT_DOUBLE_EQ (r.class_agnostic.ap25, 0.5);

  // One object split in two halves, the other perfect. From 0.5 up: 1 TP, 2 FP at one
  // score, recall 0.5 → AP = ⅓·0.25 + 1·0.25 = ⅓. At 0.25: the first half is a TP, the
  // second a duplicate FP, the other object a TP → precision ⅔ at recall 1 → AP25 = ⅔·0.5 + 0.5.
  in = twoInstances ();
  predict (in, 0, 100, 11);
  predict (in, 100, 200, 12);
  predict (in, 200, 400, 13);
  r = evaluateInstanceAP (in);
  EXPECT_NEAR (r.class_agnostic.ap50, 1.0 / 3.0, 1e-12);
  EXPECT_NEAR (r.class_agnostic.ap, 1.0 / 3.0, 1e-12);
  EXPECT_NEAR (r.class_agnostic.ap25, 5.0 / 6.0, 1e-12);

  // Confidence ranks predictions. Object 3 (300 points) is only half covered by segment
  // 14 (IoU 0.5: a false positive at 0.5, and 3 stays a false negative); 11 and 12 are
  // exact. Worked through ScanNet's PR steps: unsure 14 (0.1) → AP50 ⅔, confident 14
  // (0.95, ranked first) → 5/18.
  in = twoInstances ();
  predict (in, 0, 200, 11);
  predict (in, 200, 400, 12);
  in.truth.insert (in.truth.end (), 300, 3u);
  in.predicted.insert (in.predicted.end (), 300, 0u);
  predict (in, 500, 650, 14);
  in.predicted_instances[11] = {"", 0.9};
  in.predicted_instances[12] = {"", 0.8};
  in.predicted_instances[14] = {"", 0.1};
  EXPECT_NEAR (evaluateInstanceAP (in).class_agnostic.ap50, 2.0 / 3.0, 1e-12);
  in.predicted_instances[14].confidence = 0.95;
  EXPECT_NEAR (evaluateInstanceAP (in).class_agnostic.ap50, 5.0 / 18.0, 1e-12);

  // Classes: object 1 a cup, 2 a book; a wrong class on 2's prediction loses the book.
  in = twoInstances ();
  predict (in, 0, 200, 11);
  predict (in, 200, 400, 12);
  in.truth_instances[1] = {"cup", false};
  in.truth_instances[2] = {"book", false};
  in.predicted_instances[11] = {"cup", 1.0};
  in.predicted_instances[12] = {"cup", 1.0};
  r = evaluateInstanceAP (in);
  EXPECT_DOUBLE_EQ (r.class_agnostic.ap, 1.0);
  ASSERT_EQ (r.per_class.size (), 2u);
  EXPECT_DOUBLE_EQ (r.per_class.at ("book").ap50, 0.0);
  // cup: one TP and one FP (the book's segment) at the same score → ½ · 1 + … = 0.5 · 0.5 + 1 · 0.5
  EXPECT_DOUBLE_EQ (r.per_class.at ("cup").ap50, 0.75);
  EXPECT_DOUBLE_EQ (r.class_mean.ap50, 0.375);

  // Ignored truth (stuff) is neither found nor missed.
  in = twoInstances ();
  predict (in, 0, 200, 11);
  in.truth_instances[2] = {"wall", true};
  r = evaluateInstanceAP (in);
  EXPECT_EQ (r.truth_instances, 1u);
  EXPECT_DOUBLE_EQ (r.class_agnostic.ap, 1.0);

  // Small instances are skipped (ScanNet's min_region_size).
  InstanceAPConfig config;
  config.min_region_size = 250;
  EXPECT_EQ (evaluateInstanceAP (in, config).truth_instances, 0u);

  in.predicted.pop_back ();
  EXPECT_THROW (evaluateInstanceAP (in), Error);
}

TEST (InstanceAP, PooledOverScenesIsNotTheMeanOfSceneAPs)
{
  // Scene A: object 1 found exactly by segment 11 (confidence 0.9) → AP 1.
  InstanceEvaluationInput a = twoInstances ();
  a.truth_instances[2] = {"", true};  // only object 1 counts in A
  predict (a, 0, 200, 11);
  a.predicted_instances[11] = {"", 0.9};
  // Scene B: object 1 found exactly by segment 21 (0.3); segment 22 (0.95) lies on
  // object 2 but covers only a quarter of it (IoU 0.25 < every threshold) → a false positive
  // ranked first; object 2 stays missed.
  InstanceEvaluationInput b = twoInstances ();
  predict (b, 0, 200, 21);
  predict (b, 200, 250, 22);
  b.predicted_instances[21] = {"", 0.3};
  b.predicted_instances[22] = {"", 0.95};
  InstanceAPConfig small;
  small.min_region_size = 10;  // segment 22 has 50 points
  const InstanceAPResult ra = evaluateInstanceAP (a, small);
  const InstanceAPResult rb = evaluateInstanceAP (b, small);
  EXPECT_DOUBLE_EQ (ra.class_agnostic.ap50, 1.0);
  // B by ScanNet's steps (scores ascending 0.3 TP, 0.95 FP; 2 truths, 1 missed):
  //   at 0.3:  tp 1, fp 1, fn 1 → p ½, r ½;  at 0.95: tp 0, fp 1, fn 2 → p 0, r 0;  then (1, 0).
  //   recall padded [½, ½, 0, 0, 0] → widths ¼, ¼, 0 → AP = ½·¼ + 0·¼ = ⅛.
  EXPECT_DOUBLE_EQ (rb.class_agnostic.ap50, 0.125);
  // Pooled (3 truths; detections 0.3 TP, 0.9 TP, 0.95 FP; 1 missed):
  //   at 0.3:  tp 2, fp 1, fn 1 → p ⅔, r ⅔;  at 0.9: tp 1, fp 1, fn 2 → p ½, r ⅓;
  //   at 0.95: tp 0, fp 1, fn 3 → p 0, r 0;  then (1, 0).
  //   recall padded [⅔, ⅔, ⅓, 0, 0, 0] → widths ⅙, ⅓, ⅙, 0
  //   → AP = ⅔·⅙ + ½·⅓ + 0·⅙ = 1/9 + 1/6 = 5/18 ≈ 0.278, not the mean (1 + ⅛)/2 = 0.5625.
  const InstanceAPResult pooled = pooledInstanceAP ({ra.matches, rb.matches});
  EXPECT_NEAR (pooled.class_agnostic.ap50, 5.0 / 18.0, 1e-12);
  EXPECT_NEAR (pooled.class_agnostic.ap, 5.0 / 18.0, 1e-12);  // every overlap is exact or 0.25
  EXPECT_NEAR (pooled.class_agnostic.ap25, 5.0 / 18.0, 1e-12);  // 0.25 is not > 0.25
  EXPECT_EQ (pooled.truth_instances, 3u);
  EXPECT_EQ (pooled.predicted_instances, 3u);
  // Pooling one scene gives that scene's own AP.
  EXPECT_DOUBLE_EQ (pooledInstanceAP ({rb.matches}).class_agnostic.ap50, rb.class_agnostic.ap50);
  EXPECT_DOUBLE_EQ (pooledInstanceAP ({ra.matches, ra.matches}).class_agnostic.ap50, 1.0);
  // No scenes: no truth, AP undefined.
  EXPECT_TRUE (std::isnan (pooledInstanceAP ({}).class_agnostic.ap50));

  // Classes: a scene whose only "cup" prediction has no cup truth adds a false positive to
  // the cups of the other scene, ranked above its true positive.
  InstanceEvaluationInput c = twoInstances ();
  predict (c, 0, 200, 31);
  c.truth_instances[1] = {"cup", false};
  c.truth_instances[2] = {"book", true};
  c.predicted_instances[31] = {"cup", 0.5};
  InstanceEvaluationInput d = twoInstances ();
  predict (d, 0, 200, 41);
  d.truth_instances[1] = {"book", false};
  d.truth_instances[2] = {"lamp", true};
  d.predicted_instances[41] = {"cup", 0.8};
  const InstanceAPResult rd = evaluateInstanceAP (d);
  EXPECT_EQ (rd.per_class.count ("cup"), 0u);  // no cup truth in d: no AP of its own
  ASSERT_EQ (rd.matches.per_class.count ("cup"), 1u);
  const InstanceAPResult classes = pooledInstanceAP ({evaluateInstanceAP (c).matches, rd.matches});
  // cup: 0.5 TP, 0.8 FP, 1 truth → at 0.5: p ½, r 1; at 0.8: p 0, r 0 → widths ½, ½ → ¼.
  EXPECT_DOUBLE_EQ (classes.per_class.at ("cup").ap50, 0.25);
  EXPECT_DOUBLE_EQ (classes.per_class.at ("book").ap50, 0.0);  // d's book has no prediction
  EXPECT_DOUBLE_EQ (classes.class_mean.ap50, 0.125);

  // Lists at other thresholds do not pool.
  ThresholdMatches at50, at25;
  at25.threshold = 0.25;
  EXPECT_THROW (poolMatches (at50, at25), Error);
}
