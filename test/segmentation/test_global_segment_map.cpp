// SPDX-License-Identifier: BSD-3-Clause
// The global segment map (§4.2.2–4.2.4): label equivalence, merge confidences,
// propagation and voxel label updates over a synthetic sequence with exact truth.
#include "test_utils.h"

#include <cuefusion/simulation/synthetic_sequence.h>
#include <cuefusion/reconstruction/tsdf_volume.h>
#include <cuefusion/reconstruction/vertex_maps.h>
#include <cuefusion/segmentation/edge_operators.h>
#include <cuefusion/segmentation/fragmentation.h>
#include <cuefusion/segmentation/global_segment_map.h>
#include <cuefusion/segmentation/object_geometry.h>
#include <cuefusion/segmentation/segment_propagation.h>
#include <cuefusion/segmentation/segments_file.h>

#include <cuefusion/common/cpu_features.h>
#include <cuefusion/common/exceptions.h>
#include <gtest/gtest.h>
#include <opencv2/imgproc.hpp>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <limits>
#include <iostream>
#include <functional>
#include <map>
#include <random>
#include <set>
#include <string>
#include <tuple>

using namespace cuefusion;
using namespace cuefusion::segmentation;

TEST (LabelEquivalence, MergesResolveOnReadAndCompact)
{
  LabelEquivalence eq;
  EXPECT_EQ (eq.find (7), 7u);
  EXPECT_EQ (eq.unite (3, 7), 3u);
  EXPECT_EQ (eq.unite (7, 9), 3u);  // 9 joins 7's root, which is 3
  EXPECT_EQ (eq.unite (1, 3), 1u);
  for (const std::uint32_t l : {1u, 3u, 7u, 9u})
    EXPECT_EQ (eq.find (l), 1u) << l;
  EXPECT_EQ (eq.find (5), 5u);
  EXPECT_EQ (eq.find (0), 0u);
  eq.compact ();
  EXPECT_EQ (eq.find (9), 1u);
}

TEST (PairEvidence, UnitesAfterFiveFramesTogetherWhileTheyAreTheMajority)
{
  PairEvidence evidence;
  for (int frame = 0; frame < 4; ++frame)
    evidence.add (5, 2, PairVote::Together);
  EXPECT_EQ (evidence.counts (2, 5).together, 4);
  EXPECT_FALSE (evidence.united (2, 5));  // four frames: not yet
  evidence.add (2, 5, PairVote::Together);
  EXPECT_TRUE (evidence.united (5, 2));
  // Frames that see the pair apart outvote it: 5 together against 5 apart is no majority.
  for (int frame = 0; frame < 5; ++frame)
    evidence.add (2, 5, PairVote::Apart);
  EXPECT_EQ (evidence.counts (5, 2).apart, 5);
  EXPECT_FALSE (evidence.united (2, 5));
  evidence.add (2, 5, PairVote::Together);
  EXPECT_TRUE (evidence.united (2, 5));
  // A label never pairs with itself or with 0.
  evidence.add (3, 3, PairVote::Together);
  evidence.add (0, 3, PairVote::Together);
  EXPECT_EQ (evidence.trackedPairs (), 1u);
  EXPECT_FALSE (evidence.tracked (3, 4));

  GlobalSegmentMapConfig bad;
  bad.together_share = 1.f;
  EXPECT_THROW (PairEvidence {bad}, ParameterError);
  // The flat-surface fields name themselves (0 switches the rule off).
  for (const auto& [field, set] : std::vector<std::pair<std::string, std::function<void (GlobalSegmentMapConfig&)>>>{
           {"surface_min_extent", [] (GlobalSegmentMapConfig& c) { c.surface_min_extent = -1.f; }},
           {"surface_tolerance", [] (GlobalSegmentMapConfig& c) { c.surface_tolerance = 0.f; }},
           {"surface_max_angle_deg", [] (GlobalSegmentMapConfig& c) { c.surface_max_angle_deg = 90.f; }}})
  {
    GlobalSegmentMapConfig c;
    set (c);
    test::expectError ([&] { c.validate (); }, "GlobalSegmentMapConfig::" + field, "must lie in");
  }
  GlobalSegmentMapConfig off;
  off.surface_min_extent = 0.f;
  EXPECT_NO_THROW (off.validate ());
}

TEST (GlobalSegmentMap, AClassNeedsVotesInAQuarterOfTheFramesSeen)
{
  GlobalSegmentMap map;
  const std::uint32_t floor = map.newSegment (0);
  SegmentInstance teddy;
  teddy.instance = 0;
  teddy.class_name = "teddy bear";
  teddy.score = 0.9f;
  map.observe (floor, 0, &teddy);  // one stray mask
  for (std::size_t frame = 1; frame < 20; ++frame)
    map.observe (floor, frame);
  EXPECT_EQ (map.record (floor)->frames_seen, 20u);
  EXPECT_EQ (map.record (floor)->bestClass (), "");
  for (std::size_t frame = 20; frame < 25; ++frame)
    map.observe (floor, frame, &teddy);  // 6 of 25 frames: still below a quarter
  EXPECT_EQ (map.record (floor)->bestClass (), "");
  map.observe (floor, 25, &teddy);  // 7 of 26
  EXPECT_EQ (map.record (floor)->bestClass (), "teddy bear");
}

TEST (GlobalSegmentMap, AWrongMergeIsUndoneWhenLaterFramesSeeThePairApart)
{
  // A detector merges two touching objects (labels a, b) in the first six frames, then
  // separates them; an L's two arms (c, d) are united by every frame.
  GlobalSegmentMap map;
  const std::uint32_t a = map.newSegment (0), b = map.newSegment (0), c = map.newSegment (0), d = map.newSegment (0);
  std::size_t changes = 0;
  for (int frame = 0; frame < 6; ++frame)
    changes += map.addEvidence ({{a, b, PairVote::Together}, {c, d, PairVote::Together}});
  EXPECT_EQ (map.resolve (b), a);
  EXPECT_EQ (map.resolve (d), c);
  EXPECT_EQ (changes, 2u);
  EXPECT_EQ (map.segments ().size (), 2u);
  for (int frame = 0; frame < 6; ++frame)
    map.addEvidence ({{a, b, PairVote::Apart}, {c, d, PairVote::Together}});
  EXPECT_EQ (map.resolve (b), b);  // undone: no voxel was ever rewritten, reads resolve apart again
  EXPECT_EQ (map.resolve (a), a);
  EXPECT_EQ (map.resolve (d), c);
  EXPECT_EQ (map.segments ().size (), 3u);
}

TEST (GlobalSegmentMap, MergeKeepsTheOlderLabelAndCombinesRecords)
{
  GlobalSegmentMap map;
  const std::uint32_t a = map.newSegment (0), b = map.newSegment (3);
  SegmentInstance cup;
  cup.instance = 0;
  cup.class_name = "cup";
  cup.score = 0.8f;
  map.observe (b, 4, &cup);
  map.observe (b, 6, &cup);
  map.observe (a, 5);
  EXPECT_EQ (map.merge (b, a), a);
  EXPECT_EQ (map.resolve (b), a);
  const std::optional<SegmentRecord> record = map.record (b);
  ASSERT_TRUE (record);
  EXPECT_EQ (record->id, a);
  EXPECT_EQ (record->first_frame, 0u);
  EXPECT_EQ (record->last_frame, 6u);
  EXPECT_EQ (record->bestClass (), "cup");
  EXPECT_FLOAT_EQ (record->bestScore (), 0.8f);
  EXPECT_EQ (map.segments ().size (), 1u);
}

namespace
{
/** A static scene, 30 frames with exact poses and masks, fused with its labels. */
class PropagationFixture : public ::testing::Test
{
protected:
  void
  SetUp () override
  {
    simulation::SyntheticSequenceConfig config;
    config.frames = 30;
    config.width = 320;
    config.height = 240;
    sequence.reset (new simulation::SyntheticSequence (simulation::SyntheticScene::load (test::tabletopScenePath ()), config));
    reconstruction::TSDFVolumeConfig volume_config;
    volume_config.voxel_size = 0.01;
    volume.reset (new reconstruction::TSDFVolume (volume_config));
    volume->setRecordObservedSurface (true);
    layer.reset ();
  }

  /** L^m of a raycast: the labels of the voxels it hit. */
  cv::Mat
  modelLabels (const reconstruction::RaycastResult& model) const
  {
    cv::Mat labels;
    layer.labelImage (model.voxels, labels);
    return labels;
  }

  /** L_t for frame i: the true instances under ids that change every frame, so that only
    * propagation can make them stable.
    */
  static cv::Mat
  frameLabels (const RGBDFrame& frame, std::size_t i)
  {
    cv::Mat labels (frame.instance_mask.size (), CV_32S);
    for (int y = 0; y < labels.rows; ++y)
      for (int x = 0; x < labels.cols; ++x)
      {
        const int id = frame.instance_mask.at<std::uint16_t> (y, x);
        labels.at<std::int32_t> (y, x) = id == 0 ? 0 : static_cast<int> ((id * 7 + i * 13) % 101) + 1;
      }
    return labels;
  }

  /** Integrate frame i, raycast, propagate, update the voxels; returns L^p. */
  cv::Mat
  step (std::size_t i, const cv::Mat& frame_labels_override = cv::Mat (),
        const std::function<void (cv::Mat& normals)>& perturb_normals = nullptr, RGBDFrame::Ptr rendered = nullptr)
  {
    const RGBDFrame::Ptr frame = rendered ? rendered : sequence->frame (i);  // a frame the test rendered already
    const Eigen::Isometry3d pose = sequence->poseAt (i);
    volume->integrate (frame->depth, frame->color, frame->camera, pose);
    reconstruction::RaycastResult model;
    volume->raycast (frame->camera, pose, model);
    cv::Mat vertices, normals;
    reconstruction::computeVertexMap (frame->depth, frame->camera, vertices);
    reconstruction::computeNormalMap (vertices, normals);
    if (perturb_normals)
      perturb_normals (normals);
    PropagationResult result;
    propagation.propagate (vertices, normals, frame_labels_override.empty () ? frameLabels (*frame, i) : frame_labels_override,
                           model.vertices, model.normals, modelLabels (model), map, i, result);
    // CUEFUSION_TEST_VERBOSE=1 lists the merges the map confirms.
    const std::size_t changed = map.addEvidence (result.votes);
    if (std::getenv ("CUEFUSION_TEST_VERBOSE") && changed)
      std::cerr << "frame " << i << ": " << changed << " labels changed object\n";
    writes += updateVoxelLabels (*volume, layer, result.labels, map);
    truth = frame->instance_mask;
    last_labels = result.labels;
    return result.labels;
  }

  /** The label most pixels of object \a id carry in \a labels (0 when none). */
  std::uint32_t
  majority (const cv::Mat& labels, std::uint16_t id) const
  {
    std::map<std::int32_t, int> votes;
    for (int y = 0; y < labels.rows; ++y)
      for (int x = 0; x < labels.cols; ++x)
        if (truth.at<std::uint16_t> (y, x) == id && labels.at<std::int32_t> (y, x) > 0)
          ++votes[labels.at<std::int32_t> (y, x)];
    std::uint32_t best = 0;
    int best_votes = 0;
    for (const auto& [label, n] : votes)
      if (n > best_votes)
      {
        best = static_cast<std::uint32_t> (label);
        best_votes = n;
      }
    return map.resolve (best);
  }

  /** Fuses the 30 frames with a patch of the table top (14 × 10 cm at x 0.12–0.26, y
    * −0.36 to −0.26: in front of every object, as the camera sees it) its own frame
    * segment in the first \a labelled frames and unlabelled after, a ring of no label
    * (3 cm, 6 px and more here) around it so that no frame judges it with the table.
    * \a patch: its label in frame 0; \a table: the table's label in the last frame.
    */
  void
  fuseWithTablePatch (std::size_t labelled, std::uint32_t& patch, std::uint32_t& table)
  {
    auto inBox = [] (const Eigen::Vector3d& p, double grow) {
      return p.x () > 0.12 - grow && p.x () < 0.26 + grow && p.y () > -0.36 - grow && p.y () < -0.26 + grow;
    };
    for (std::size_t i = 0; i < 30; ++i)
    {
      const RGBDFrame::Ptr frame = sequence->frame (i);
      const Eigen::Isometry3d pose = sequence->poseAt (i);
      const PinholeCamera& camera = frame->camera;
      cv::Mat labels = frameLabels (*frame, i);
      cv::Point centre (-1, -1);
      for (int y = 0; y < labels.rows; ++y)
        for (int x = 0; x < labels.cols; ++x)
        {
          const float z = frame->depth.at<float> (y, x);
          if (frame->instance_mask.at<std::uint16_t> (y, x) != 4 || !(z > 0.f))
            continue;
          const Eigen::Vector3d world = pose * Eigen::Vector3d ((x - camera.cx) / camera.fx * z, (y - camera.cy) / camera.fy * z, z);
          if (inBox (world, 0.0))
          {
            labels.at<std::int32_t> (y, x) = i < labelled ? 250 : 0;
            if (centre.x < 0 && inBox (world, -0.03))
              centre = cv::Point (x, y);
          }
          else if (inBox (world, 0.03))
            labels.at<std::int32_t> (y, x) = 0;
        }
      ASSERT_GE (centre.x, 0) << "the patch is not in view, frame " << i;
      const cv::Mat lp = step (i, labels, nullptr, frame);
      if (i == 0)
        patch = static_cast<std::uint32_t> (lp.at<std::int32_t> (centre));
      table = majority (lp, 4);
    }
  }

  std::unique_ptr<simulation::SyntheticSequence> sequence;
  std::unique_ptr<reconstruction::TSDFVolume> volume;
  VoxelLabelLayer layer;
  GlobalSegmentMap map;
  SegmentPropagation propagation;
  cv::Mat truth, last_labels;  ///< the last frame's instances and L^p
  std::size_t writes = 0;
};
}  // namespace

TEST_F (PropagationFixture, LabelsStayStableOverAStaticSequence)
{
  std::map<std::uint16_t, std::uint32_t> first;
  const cv::Mat l0 = step (0);
  const std::vector<std::uint16_t> objects = {5, 6, 7, 8, 9, 10, 11, 12};  // the table-top objects (ids in file order)
  for (const std::uint16_t id : objects)
    first[id] = majority (l0, id);
  for (std::size_t i = 1; i < 30; ++i)
  {
    const cv::Mat lp = step (i);
    for (const std::uint16_t id : objects)
      if (first[id] != 0 && cv::countNonZero (truth == id) > 200)
      {
        EXPECT_EQ (majority (lp, id), first[id]) << "object " << id << " frame " << i;
      }
  }
  // Different objects kept different labels, and the map knows them all.
  std::set<std::uint32_t> distinct;
  for (const auto& [id, label] : first)
    if (label)
      distinct.insert (label);
  EXPECT_GE (distinct.size (), 6u);
  EXPECT_EQ (distinct.size (), static_cast<std::size_t> (std::count_if (first.begin (), first.end (), [] (const auto& e) { return e.second != 0; })));
  map.refreshStatistics (*volume, layer);
  for (const std::uint32_t label : distinct)
  {
    ASSERT_TRUE (map.record (label));
    EXPECT_GT (map.record (label)->voxels, 20u) << label;
  }
}

TEST_F (PropagationFixture, OneNoisyFrameDoesNotFlipVoxelLabelsAndMergesWriteNoVoxel)
{
  for (std::size_t i = 0; i < 12; ++i)
    step (i);
  reconstruction::RaycastResult model;
  const Eigen::Isometry3d pose = sequence->poseAt (11);
  volume->raycast (sequence->camera (), pose, model);
  const cv::Mat before = resolveLabels (modelLabels (model), map);
  const std::uint32_t mug = majority (before, 5), ball = majority (before, 6);
  ASSERT_NE (mug, 0u);
  ASSERT_NE (ball, 0u);
  ASSERT_NE (mug, ball);

  // One frame in which the mug is labelled as the ball: Ψ only drops.
  const RGBDFrame::Ptr frame = sequence->frame (11);
  cv::Mat wrong = cv::Mat::zeros (frame->instance_mask.size (), CV_32S);
  wrong.setTo (static_cast<int> (ball), frame->instance_mask == 5);
  updateVoxelLabels (*volume, layer, wrong, map);
  volume->raycast (sequence->camera (), pose, model);
  EXPECT_EQ (majority (resolveLabels (modelLabels (model), map), 5), mug);

  // A merge is an equivalence entry: no voxel changes, yet reads resolve to one label.
  std::vector<std::uint32_t> stored;
  for (std::size_t id = 0; id < layer.blockCount (); ++id)
    stored.insert (stored.end (), layer.block (id).labels.begin (), layer.block (id).labels.end ());
  EXPECT_EQ (map.merge (mug, ball), std::min (mug, ball));
  std::size_t k = 0, changed = 0;
  for (std::size_t id = 0; id < layer.blockCount (); ++id)
    for (const std::uint32_t label : layer.block (id).labels)
      changed += label != stored[k++] ? 1 : 0;
  EXPECT_EQ (changed, 0u);
  volume->raycast (sequence->camera (), pose, model);
  const cv::Mat after = resolveLabels (modelLabels (model), map);
  EXPECT_EQ (majority (after, 5), majority (after, 6));
}

TEST_F (PropagationFixture, VectorKernelsLabelTheMapAsTheScalarOnes)
{
  if (!cpuHasAvx2Fma ())
    GTEST_SKIP () << "this CPU has no AVX2/FMA: only the scalar kernels run";
  // The same ten frames fused twice, once with each kernel set (integration, propagation
  // and the label update); every frame's L^p and every voxel's resolved label and Ψ are
  // compared.
  const bool before = vectorKernelsEnabled ();
  std::map<std::tuple<int, int, int, int>, std::pair<std::uint32_t, int>> labelled[2];
  std::vector<cv::Mat> propagated[2];
  for (const bool vector : {false, true})
  {
    setVectorKernelsEnabled (vector);
    SetUp ();
    map = GlobalSegmentMap ();
    for (std::size_t i = 0; i < 10; ++i)
      propagated[vector].push_back (step (i).clone ());
    for (std::size_t id = 0; id < layer.blockCount (); ++id)
      for (int i = 0; i < reconstruction::kBlockVoxels; ++i)
      {
        const Eigen::Vector3i& index = volume->store ().block (id).index;
        const std::uint32_t label = layer.block (id).labels[static_cast<std::size_t> (i)];
        if (label != 0)
          labelled[vector][{index.x (), index.y (), index.z (), i}] = {map.resolve (label),
                                                                       layer.block (id).confidence[static_cast<std::size_t> (i)]};
      }
  }
  setVectorKernelsEnabled (before);
  for (std::size_t i = 0; i < 10; ++i)
  {
    const int labelled_pixels = cv::countNonZero (propagated[0][i]);
    ASSERT_GT (labelled_pixels, 5000);
    EXPECT_LT (cv::countNonZero (propagated[0][i] != propagated[1][i]), labelled_pixels / 200) << "frame " << i;
  }
  ASSERT_GT (labelled[0].size (), 20000u);
  std::size_t same = 0;
  for (const auto& [key, value] : labelled[0])
  {
    const auto it = labelled[1].find (key);
    same += it != labelled[1].end () && it->second == value;
  }
  EXPECT_GT (static_cast<double> (same), 0.995 * static_cast<double> (labelled[0].size ()));
  EXPECT_NEAR (static_cast<double> (labelled[1].size ()), static_cast<double> (labelled[0].size ()),
               0.005 * static_cast<double> (labelled[0].size ()));
}

TEST_F (PropagationFixture, LabelUpdateTouchesExactlyTheVoxelsTheFrameSawInTheBand)
{
  // §4.2.4's voxel set, worked out here from the geometry: a voxel of a block the frame
  // integrated is labelled iff the frame updated it, its nearest pixel is labelled, that
  // pixel's depth lies within band · τ of the voxel (along the pixel's ray) and its fused
  // |sdf| < band. Frames 0 and 20 see the table from different places, so fused and
  // observed distances differ; only the left half of L^p is labelled.
  const bool before = vectorKernelsEnabled ();
  const RGBDFrame::Ptr first = sequence->frame (0), frame = sequence->frame (20);
  const Eigen::Isometry3d pose = sequence->poseAt (20);
  const PinholeCamera& camera = frame->camera;
  cv::Mat labels = cv::Mat::zeros (frame->depth.size (), CV_32S);
  labels.colRange (0, labels.cols / 2).setTo (7);
  const float truncation = static_cast<float> (volume->getConfig ().truncation ());
  for (const bool vector : {false, true})
    for (const float band : {1.f, 0.5f})
    {
      if (vector && !cpuHasAvx2Fma ())
        continue;
      setVectorKernelsEnabled (vector);
      SetUp ();
      volume->integrate (first->depth, first->color, first->camera, sequence->poseAt (0));
      std::map<std::size_t, float> weight_before;
      for (std::size_t b = 0; b < volume->store ().size (); ++b)
        for (int i = 0; i < reconstruction::kBlockVoxels; ++i)
          weight_before[b * reconstruction::kBlockVoxels + static_cast<std::size_t> (i)] = volume->store ().block (b).voxels[static_cast<std::size_t> (i)].weight;
      volume->integrate (frame->depth, frame->color, camera, pose);
      // The list integration made: each voxel once, all inside the band.
      std::set<std::uint32_t> listed;
      for (const auto& list : volume->lastObservedSurface ())
        for (const reconstruction::SurfaceObservation& seen : list)
        {
          EXPECT_TRUE (listed.insert (seen.voxel).second);
          EXPECT_LT (seen.gap, truncation);
          const float sdf = volume->store ().block (seen.voxel / reconstruction::kBlockVoxels).voxels[seen.voxel % reconstruction::kBlockVoxels].sdf;
          EXPECT_LT (std::abs (sdf), 1.f);
          EXPECT_EQ (seen.sdf, sdf);  // the fused distance, as the voxel holds it
        }
      VoxelLabelUpdateConfig config;
      config.band = band;
      const std::size_t writes = updateVoxelLabels (*volume, layer, labels, GlobalSegmentMap (), config);

      std::set<std::size_t> expected, labelled;
      const Eigen::Isometry3d world_to_camera = pose.inverse ();
      for (const std::int32_t id : volume->lastIntegratedBlocks ())
      {
        const reconstruction::VoxelBlock& block = volume->store ().block (static_cast<std::size_t> (id));
        for (int i = 0; i < reconstruction::kBlockVoxels; ++i)
        {
          const std::size_t key = static_cast<std::size_t> (id) * reconstruction::kBlockVoxels + static_cast<std::size_t> (i);
          const reconstruction::TsdfVoxel& voxel = block.voxels[static_cast<std::size_t> (i)];
          if (layer.label (static_cast<reconstruction::VoxelNumber> (key)) != 0)
            labelled.insert (key);
          const auto it = weight_before.find (key);
          if (!(voxel.weight > (it == weight_before.end () ? 0.f : it->second)))
            continue;  // not updated by this frame
          const Eigen::Vector3i v = block.index * reconstruction::kBlockSide +
                                    Eigen::Vector3i (i % 8, (i / 8) % 8, i / 64);
          const Eigen::Vector3d p = world_to_camera * (v.cast<double> () * volume->getConfig ().voxel_size);
          const int u = static_cast<int> (std::floor (camera.fx * p.x () / p.z () + camera.cx + 0.5));
          const int r = static_cast<int> (std::floor (camera.fy * p.y () / p.z () + camera.cy + 0.5));
          ASSERT_TRUE (u >= 0 && r >= 0 && u < camera.width && r < camera.height);  // it was updated
          if (labels.at<std::int32_t> (r, u) > 0 && std::abs (p.z () - frame->depth.at<float> (r, u)) < band * truncation &&
              std::abs (voxel.sdf) < band)
            expected.insert (key);
        }
      }
      std::size_t missing = 0, extra = 0;
      for (const std::size_t key : expected)
        missing += labelled.count (key) == 0;
      for (const std::size_t key : labelled)
        extra += expected.count (key) == 0;
      const std::string what = std::string (vector ? "vector" : "scalar") + " kernels, band " + std::to_string (band);
      ASSERT_GT (expected.size (), 5000u) << what;
      EXPECT_EQ (writes, labelled.size ()) << what;  // every write labelled an unlabelled voxel
      // Rounding of the voxel positions (float, stepped) may move a voxel on a pixel border.
      EXPECT_LT (missing + extra, expected.size () / 500) << what << ": " << missing << " missing, " << extra << " extra";
    }
  setVectorKernelsEnabled (before);

  // Misuse: a volume that does not record what it integrates, or L^p of another size.
  volume->setRecordObservedSurface (false);
  volume->integrate (frame->depth, frame->color, camera, pose);
  EXPECT_THROW (updateVoxelLabels (*volume, layer, labels, GlobalSegmentMap ()), Error);
  volume->setRecordObservedSurface (true);
  volume->integrate (frame->depth, frame->color, camera, pose);
  EXPECT_THROW (updateVoxelLabels (*volume, layer, labels.colRange (0, 100).clone (), GlobalSegmentMap ()), Error);
  EXPECT_GT (updateVoxelLabels (*volume, layer, labels, GlobalSegmentMap ()), 0u);
}

TEST_F (PropagationFixture, AnEdgeTheFusedSurfaceDoesNotShowUnitesThePiecesItParts)
{
  // No masks. Every frame cuts the table (object 4) in two along a one-pixel line of no
  // label at the image's middle column, where the frame's normals show a concave crease
  // of ~33° (as noise can) that the fused surface, integrated from the exact depth, does
  // not: the pieces are one object after the first frames. The table and the floor
  // (object 1), parted by its rim, a depth jump in the model too, stay apart. With
  // model_edge_share 0 every such edge parts the pieces (the rule before), and the halves
  // stay two. 12 frames: the pieces need confirm_confidence (5).
  auto run = [this] (float model_edge_share) {
    SegmentPropagationConfig config;
    config.model_edge_share = model_edge_share;
    propagation = SegmentPropagation (config);
    map = GlobalSegmentMap ();
    layer = VoxelLabelLayer ();
    SetUp ();
    std::uint32_t left = 0, right = 0, floor = 0;
    for (std::size_t i = 0; i < 12; ++i)
    {
      const RGBDFrame::Ptr frame = sequence->frame (i);
      cv::Mat labels = frameLabels (*frame, i);
      const int middle = labels.cols / 2;
      for (int y = 0; y < labels.rows; ++y)
        for (int x = middle; x < labels.cols; ++x)
          if (frame->instance_mask.at<std::uint16_t> (y, x) == 4)
            labels.at<std::int32_t> (y, x) = x == middle ? 0 : 200;  // the right half: its own frame segment
      const cv::Mat mask = frame->instance_mask.clone ();
      const cv::Mat lp = step (
        i, labels,
        [&] (cv::Mat& normals) {
        for (int y = 0; y < normals.rows; ++y)
          for (int x = middle - 2; x <= middle + 2; ++x)
            if (x != middle && mask.at<std::uint16_t> (y, x) == 4)
            {
              cv::Vec3f& n = normals.at<cv::Vec3f> (y, x);
              n[0] += x < middle ? 0.3f : -0.3f;  // turned towards each other: a valley
              n /= cv::norm (n);
            }
        },
        frame);
      cv::Mat left_half = cv::Mat::zeros (truth.size (), CV_16U), right_half = cv::Mat::zeros (truth.size (), CV_16U);
      truth.colRange (0, middle).copyTo (left_half.colRange (0, middle));
      truth.colRange (middle + 1, truth.cols).copyTo (right_half.colRange (middle + 1, truth.cols));
      const cv::Mat keep = truth.clone ();
      truth = left_half;
      left = majority (lp, 4);
      truth = right_half;
      right = majority (lp, 4);
      truth = keep;
      floor = majority (lp, 1);
    }
    EXPECT_NE (left, 0u);
    EXPECT_NE (right, 0u);
    EXPECT_NE (floor, 0u);
    EXPECT_NE (map.resolve (floor), map.resolve (left)) << "model_edge_share " << model_edge_share;
    return map.resolve (left) == map.resolve (right);
  };
  EXPECT_TRUE (run (SegmentPropagationConfig ().model_edge_share));
  EXPECT_FALSE (run (0.f));
}

TEST_F (PropagationFixture, ASplinterCarriedInFewOfTheFramesThatSawItSettlesIntoItsSurface)
{
  // A patch of the table is its own frame segment in frames 0–4 (apart from the table by
  // a ring of no label, so no frame judges the pair), then unlabelled for 25 frames: its
  // voxels keep its label, seen in 5 of the 30 frames that fused them. Five frames
  // confirm it by count (confirm_confidence); the share of frames (confirm_share) does
  // not, and outputs show it as the table it lies on.
  std::uint32_t splinter = 0, table = 0;
  fuseWithTablePatch (5, splinter, table);
  ASSERT_NE (splinter, 0u);
  ASSERT_NE (map.resolve (splinter), map.resolve (table));
  const std::optional<SegmentRecord> record = map.record (splinter);
  ASSERT_TRUE (record);
  EXPECT_GE (record->frames_seen, static_cast<std::size_t> (GlobalSegmentMapConfig ().confirm_confidence));
  const auto settled = map.settledLabels (*volume, layer);
  ASSERT_TRUE (settled.count (splinter));
  ASSERT_TRUE (settled.count (table));
  EXPECT_EQ (settled.at (splinter), settled.at (table));
}

TEST_F (PropagationFixture, AnObjectWhoseLabelsTheSurfaceDoesNotShowSettlesIntoItsNeighbour)
{
  // A patch of the table top is its own frame segment in all 30 frames (a ring of no label
  // around it), so it is confirmed. Then its voxels within half the truncation band of
  // the surface take the table's label: its label remains only in voxels in front of and
  // behind the surface, which no point of the map shows. Outputs show it as the table.
  std::uint32_t patch = 0, table = 0;
  fuseWithTablePatch (30, patch, table);
  ASSERT_NE (patch, 0u);
  ASSERT_NE (map.resolve (patch), map.resolve (table));
  const auto before = map.settledLabels (*volume, layer);
  ASSERT_TRUE (before.count (patch));
  ASSERT_EQ (before.at (patch), map.resolve (patch)) << "the patch is not confirmed while the surface shows it";
  // A zero crossing's nearer voxel lies within a voxel of the surface: |sdf| < 0.5 of the band.
  std::size_t kept = 0, moved = 0;
  const reconstruction::VoxelBlockStore& blocks = volume->store ();
  for (std::size_t id = 0; id < std::min (blocks.size (), layer.blockCount ()); ++id)
    for (std::size_t v = 0; v < static_cast<std::size_t> (reconstruction::kBlockVoxels); ++v)
    {
      std::uint32_t& label = layer.block (id).labels[v];
      if (label == 0 || map.resolve (label) != map.resolve (patch) || !(blocks.block (id).voxels[v].weight > 0.f))
        continue;
      const bool near = std::abs (blocks.block (id).voxels[v].sdf) < 0.5f;
      label = near ? table : label;
      ++(near ? moved : kept);
    }
  ASSERT_GT (moved, 0u);
  ASSERT_GT (kept, 0u) << "no voxel of the band keeps the patch's label";
  const auto after = map.settledLabels (*volume, layer);
  ASSERT_TRUE (after.count (patch));
  ASSERT_TRUE (after.count (table));
  EXPECT_EQ (after.at (patch), after.at (table));
  pcl::PointCloud<pcl::PointXYZRGBL> cloud;
  volume->extractPointCloud (cloud, nullptr, [this] (reconstruction::VoxelNumber v) { return map.resolve (layer.label (v)); });
  for (const auto& p : cloud)
    ASSERT_NE (p.label, map.resolve (patch)) << "a point of the map still shows the patch: the test's premise";
}

TEST_F (PropagationFixture, APatchOfAFlatSurfaceThatNoFrameJudgedShowsAsTheSurfaceItTouches)
{
  // A patch of the table top (14 × 10 cm, narrower than surface_min_extent) is its own
  // frame segment in all 30 frames, with a ring of no label around it, so that no frame
  // judges it with the table (what a strip of a floor seen only between the slats of a
  // chair's back is). Confirmed, it shows as itself while it touches nothing (the ring's
  // voxels carry no label); once the ring's voxels are the table's, it touches the table
  // it lies on and shows as the table. The book on the table, which frames judged,
  // stays itself throughout.
  std::uint32_t patch = 0, table = 0;
  fuseWithTablePatch (30, patch, table);
  ASSERT_NE (patch, 0u);
  ASSERT_NE (map.resolve (patch), map.resolve (table));
  const std::uint32_t book = majority (last_labels, 7);
  ASSERT_NE (book, 0u);
  ASSERT_NE (map.resolve (book), map.resolve (table));
  const auto before = map.settledLabels (*volume, layer);
  ASSERT_TRUE (before.count (patch) && before.count (table));
  ASSERT_NE (before.at (patch), before.at (table)) << "the patch touches the table without the ring: the test's premise";
  // The ring (x 0.09–0.29, y −0.39 to −0.23 around the patch) on the table top, as the table.
  const double voxel = volume->getConfig ().voxel_size;
  std::size_t filled = 0;
  const reconstruction::VoxelBlockStore& blocks = volume->store ();
  for (std::size_t id = 0; id < std::min (blocks.size (), layer.blockCount ()); ++id)
    for (int i = 0; i < reconstruction::kBlockVoxels; ++i)
    {
      const std::size_t v = static_cast<std::size_t> (i);
      const Eigen::Vector3d p =
        (blocks.block (id).index * reconstruction::kBlockSide + reconstruction::localVoxelPosition (i)).cast<double> () * voxel;
      if (layer.block (id).labels[v] != 0 || !(blocks.block (id).voxels[v].weight > 0.f) || p.x () < 0.09 || p.x () > 0.29 ||
          p.y () < -0.39 || p.y () > -0.23 || p.z () < 0.70 || p.z () > 0.78)
        continue;
      layer.block (id).labels[v] = table;
      ++filled;
    }
  ASSERT_GT (filled, 0u);
  const auto after = map.settledLabels (*volume, layer);
  ASSERT_TRUE (after.count (patch) && after.count (table) && after.count (book));
  EXPECT_EQ (after.at (patch), after.at (table));
  EXPECT_NE (after.at (book), after.at (table));
}

TEST_F (PropagationFixture, PiecesWhoseVotesSpreadOverManyLabelPairsShowAsOneObject)
{
  // The patch of the table top (its own frame segment in all 30 frames, a ring of no
  // label around it: no frame judged it with the table) and the table, given a second
  // label of its own (a label it took in some frames, as a surface whose label changes
  // from frame to frame does). Three frames vote Together on the patch and one of the
  // table's labels, three on the patch and the other: fewer than confirm_confidence on
  // either pair, so the map keeps them apart, but six in all and none apart — one
  // object in outputs (what a strip of a refrigerator's side that takes a fresh label in
  // most frames is to its front). With five votes apart as well on those pairs (summed:
  // 8 together, 5 apart; the summed rule alone would unite them), the pair is one the
  // evidence has seen apart often enough to decide, and it stays apart. Nor does a pair
  // the masks named differently join: the patch a cup in a quarter of its frames, the
  // table nothing.
  std::uint32_t patch = 0, table = 0;
  fuseWithTablePatch (30, patch, table);
  ASSERT_NE (patch, 0u);
  ASSERT_NE (map.resolve (patch), map.resolve (table));
  // Every other voxel of the table takes the second label.
  const std::uint32_t first = table, second = map.newSegment (29);
  ASSERT_EQ (map.resolve (map.merge (first, second)), map.resolve (table));
  std::size_t relabelled = 0;
  const reconstruction::VoxelBlockStore& blocks = volume->store ();
  for (std::size_t id = 0; id < std::min (blocks.size (), layer.blockCount ()); ++id)
    for (std::uint32_t& label : layer.block (id).labels)
      if (label == first && relabelled++ % 2 == 0)
        label = second;
  ASSERT_GT (relabelled, 0u);
  const auto vote = [] (GlobalSegmentMap& m, std::uint32_t a, std::uint32_t b, PairVote v, int frames) {
    for (int f = 0; f < frames; ++f)
      m.addEvidence ({std::make_tuple (a, b, v)});
  };
  const int decide = GlobalSegmentMapConfig ().confirm_confidence;
  ASSERT_EQ (decide, 5) << "the votes below are counted for confirm_confidence 5";

  GlobalSegmentMap spread = map;
  vote (spread, patch, first, PairVote::Together, 3);
  vote (spread, patch, second, PairVote::Together, 3);
  ASSERT_NE (spread.resolve (patch), spread.resolve (table)) << "a pair of labels reached confirm_confidence";
  const auto one = spread.settledLabels (*volume, layer);
  ASSERT_TRUE (one.count (patch) && one.count (table));
  EXPECT_EQ (one.at (patch), one.at (table));
  EXPECT_EQ (one.at (first), one.at (second));

  GlobalSegmentMap named = map;
  SegmentInstance cup;
  cup.instance = 0;
  cup.class_name = "cup";
  cup.score = 0.9f;
  for (int f = 0; f < 8; ++f)  // frame 29, the patch's last: frames seen stay 30
    named.observe (patch, 29, &cup);
  ASSERT_EQ (named.record (patch)->bestClass (), "cup");
  ASSERT_EQ (named.record (table)->bestClass (), "");
  vote (named, patch, first, PairVote::Together, 3);
  vote (named, patch, second, PairVote::Together, 3);
  const auto cup_and_table = named.settledLabels (*volume, layer);
  ASSERT_TRUE (cup_and_table.count (patch) && cup_and_table.count (table));
  EXPECT_NE (cup_and_table.at (patch), cup_and_table.at (table));

  GlobalSegmentMap contested = map;
  vote (contested, patch, first, PairVote::Together, 4);
  vote (contested, patch, second, PairVote::Together, 4);
  vote (contested, patch, first, PairVote::Apart, 3);
  vote (contested, patch, second, PairVote::Apart, 2);
  ASSERT_NE (contested.resolve (patch), contested.resolve (table));
  const auto two = contested.settledLabels (*volume, layer);
  ASSERT_TRUE (two.count (patch) && two.count (table));
  EXPECT_NE (two.at (patch), two.at (table));
}

TEST_F (PropagationFixture, LabelLayerKeysTheVolumesVoxelsAndItsFileRoundTrips)
{
  for (std::size_t i = 0; i < 4; ++i)
    step (i);
  ASSERT_EQ (layer.blockCount (), volume->blockCount ());
  // L^m: each pixel shows the label of the voxel the raycast reports, 0 where it hit none;
  // the raycast sampling the layer itself gives the same image.
  reconstruction::RaycastResult model;
  reconstruction::RaycastOptions options;
  options.depth_hint = sequence->frame (3)->depth;
  options.values = &layer.labelValues ();
  volume->raycast (sequence->camera (), sequence->poseAt (3), model, options);
  const cv::Mat labels = modelLabels (model);
  ASSERT_EQ (model.values.size (), labels.size ());
  EXPECT_EQ (cv::countNonZero (model.values != labels), 0);
  int hits = 0, labelled = 0;
  for (int y = 0; y < labels.rows; ++y)
    for (int x = 0; x < labels.cols; ++x)
    {
      const auto v = static_cast<reconstruction::VoxelNumber> (model.voxels.at<std::int32_t> (y, x));
      const bool hit = std::isfinite (model.vertices.at<cv::Vec3f> (y, x)[0]);
      ASSERT_EQ (v != reconstruction::kNoVoxel, hit) << x << "," << y;
      ASSERT_EQ (static_cast<std::uint32_t> (labels.at<std::int32_t> (y, x)), hit ? layer.label (v) : 0u);
      hits += hit;
      labelled += labels.at<std::int32_t> (y, x) != 0;
    }
  EXPECT_GT (labelled, hits / 2);

  // Saved with a label map, loaded for the same volume: every voxel's label mapped, Ψ kept.
  test::TempDir dir;
  const std::string path = dir / "volume.labels";
  layer.save (path, *volume, [] (std::uint32_t label) { return label + 1000; });
  const VoxelLabelLayer loaded = VoxelLabelLayer::load (path, *volume);
  ASSERT_EQ (loaded.blockCount (), volume->blockCount ());
  std::size_t voxels = 0;
  for (reconstruction::VoxelNumber v = 0; v < volume->blockCount () * reconstruction::kBlockVoxels; ++v)
  {
    const std::uint32_t label = layer.label (v);
    ASSERT_EQ (loaded.label (v), label != 0 ? label + 1000 : 0u) << v;
    ASSERT_EQ (loaded.confidence (v), layer.confidence (v)) << v;
    voxels += label != 0;
  }
  EXPECT_GT (voxels, 20000u);
  EXPECT_EQ (loaded.label (reconstruction::kNoVoxel), 0u);

  // Damaged files, and a volume without the file's blocks, are refused naming the file.
  const std::string bytes = test::readFile (path);
  test::writeFile (path + ".cut", bytes.substr (0, bytes.size () - 10));
  test::expectError ([&] { VoxelLabelLayer::load (path + ".cut", *volume); }, path + ".cut", "truncated");
  std::string other = bytes;
  other[8] = 9;  // version
  test::writeFile (path + ".v9", other);
  test::expectError ([&] { VoxelLabelLayer::load (path + ".v9", *volume); }, path + ".v9", "version 9");
  test::writeFile (path + ".txt", "not a label file, only text long enough for a header");
  test::expectError ([&] { VoxelLabelLayer::load (path + ".txt", *volume); }, path + ".txt", "not a cuefusion label file");
  test::expectError ([&] { VoxelLabelLayer::load (path, reconstruction::TSDFVolume ()); }, path, "does not have");
  test::expectError ([&] { VoxelLabelLayer::load (dir / "missing.labels", *volume); }, "missing.labels", "no such file");
}

TEST (SegmentPropagation, VectorKernelDecidesEveryPixelAsTheScalarCode)
{
  if (!cpuHasAvx2Fma ())
    GTEST_SKIP () << "this CPU has no AVX2/FMA: only the scalar kernels run";
  // Hand-made maps where each test of §4.2.2.3 decides: model vertices moved along the ray
  // by 0–3 times the noise bound (some pass only with the viewing angle's σ_d), model
  // normals turned by up to 90°, some NaN; 61 px wide so rows end in a scalar tail.
  const int w = 61, h = 48;
  cv::Mat V (h, w, CV_32FC3), N (h, w, CV_32FC3), Vm (h, w, CV_32FC3), Nm (h, w, CV_32FC3);
  cv::Mat lj (h, w, CV_32S), li (h, w, CV_32S);
  std::mt19937 rng (5);
  std::uniform_real_distribution<float> unit (0.f, 1.f);
  const float nan = std::numeric_limits<float>::quiet_NaN ();
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x)
    {
      const float z = 0.5f + 3.5f * unit (rng);
      const Eigen::Vector3f v ((x - 30) * z / 50.f, (y - 24) * z / 50.f, z);
      const Eigen::Vector3f n = Eigen::Vector3f (4.f * unit (rng) - 2.f, 4.f * unit (rng) - 2.f, -1.f).normalized ();  // up to 70° off the ray
      const float spread = (x / 6 + y / 6) % 3 == 0 ? 1.f : 3.f;  // segments that mostly agree, and others
      const float offset = spread * unit (rng) * segmentation::axialNoiseLowerBound (z);
      const Eigen::Vector3f vm = v + v.normalized () * offset;
      const float turn = (spread == 1.f ? 0.5f : 1.57f) * unit (rng);
      const Eigen::Vector3f nm = Eigen::AngleAxisf (turn, Eigen::Vector3f::UnitX ()) * n;
      V.at<cv::Vec3f> (y, x) = cv::Vec3f (v.x (), v.y (), v.z ());
      N.at<cv::Vec3f> (y, x) = unit (rng) < 0.05f ? cv::Vec3f (nan, nan, nan) : cv::Vec3f (n.x (), n.y (), n.z ());
      Vm.at<cv::Vec3f> (y, x) = unit (rng) < 0.05f ? cv::Vec3f (nan, nan, nan) : cv::Vec3f (vm.x (), vm.y (), vm.z ());
      Nm.at<cv::Vec3f> (y, x) = cv::Vec3f (nm.x (), nm.y (), nm.z ());
      lj.at<std::int32_t> (y, x) = unit (rng) < 0.1f ? 0 : 1 + (x / 6) + 11 * (y / 6);
      li.at<std::int32_t> (y, x) = unit (rng) < 0.1f ? 0 : 100 + (x / 9) + 7 * (y / 9);  // straddles frame segments
    }
  SegmentPropagationConfig config;
  config.min_segment_size = 5;
  config.inherit_overlap = 0.3f;
  PropagationResult result[2];
  // Propagates frame labels \a frame onto a fresh map with the scalar and the vector code.
  const auto both_ways = [&] (const SegmentPropagation& propagation, const cv::Mat& frame) {
    for (const bool vector : {false, true})
    {
      const bool before = vectorKernelsEnabled ();
      setVectorKernelsEnabled (vector);
      GlobalSegmentMap map;
      propagation.propagate (V, N, frame, Vm, Nm, li, map, 0, result[vector]);
      setVectorKernelsEnabled (before);
    }
  };
  both_ways (SegmentPropagation (config), lj);
  // The data is not one-sided: both inheriting and fresh segments occur.
  EXPECT_GT (result[0].inherited, 5);
  EXPECT_GT (result[0].fresh, 5);
  EXPECT_EQ (cv::countNonZero (result[0].labels != result[1].labels), 0);
  EXPECT_EQ (result[0].votes, result[1].votes);
  EXPECT_EQ (result[0].inherited, result[1].inherited);
  EXPECT_EQ (result[0].fresh, result[1].fresh);

  // Every pixel its own frame segment: a pixel inherits exactly when it agrees with the
  // model, so the two label maps compare the decisions pixel by pixel (including those
  // the vector kernel brackets by the viewing angle and the few it leaves to the acos).
  cv::Mat own (h, w, CV_32S);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x)
      own.at<std::int32_t> (y, x) = lj.at<std::int32_t> (y, x) > 0 ? 1 + y * w + x : 0;
  config.min_segment_size = 1;
  both_ways (SegmentPropagation (config), own);
  EXPECT_GT (result[0].inherited, 300);
  EXPECT_GT (result[0].fresh, 300);
  EXPECT_EQ (result[0].inherited, result[1].inherited);
  EXPECT_EQ (cv::countNonZero (result[0].labels != result[1].labels), 0);
}

TEST (SegmentPropagation, APieceWithoutFrameNormalsInheritsTheLabelOfTheSurfaceItLiesOn)
{
  // A far sliver (2.5-3.5 m): every pixel of it within the normals' span of a depth edge,
  // so the frame has no normal there, as for a cup 13 px wide between two boxes. Where
  // the model's surface lies within the noise bound along the ray it inherits the model's
  // label (before: no pixel could agree, and it took a fresh label every frame); where the
  // model's surface is 5 bounds away (another surface) it does not.
  const int w = 40, h = 40;
  cv::Mat V (h, w, CV_32FC3), N (h, w, CV_32FC3), Vm (h, w, CV_32FC3), Nm (h, w, CV_32FC3);
  cv::Mat lj (h, w, CV_32S, cv::Scalar (1)), none (h, w, CV_32S, cv::Scalar (0));
  std::mt19937 rng (29);
  std::uniform_real_distribution<float> unit (0.f, 1.f);
  const float nan = std::numeric_limits<float>::quiet_NaN ();
  const auto fill = [&] (float offset_bounds) {
    for (int y = 0; y < h; ++y)
      for (int x = 0; x < w; ++x)
      {
        const float z = 2.5f + unit (rng);
        const Eigen::Vector3f v ((x - 20) * z / 525.f, (y - 20) * z / 525.f, z);
        const Eigen::Vector3f vm = v + v.normalized () * (offset_bounds * (0.5f + 0.5f * unit (rng)) * axialNoiseLowerBound (z));
        V.at<cv::Vec3f> (y, x) = cv::Vec3f (v.x (), v.y (), v.z ());
        N.at<cv::Vec3f> (y, x) = cv::Vec3f (nan, nan, nan);
        Vm.at<cv::Vec3f> (y, x) = cv::Vec3f (vm.x (), vm.y (), vm.z ());
        Nm.at<cv::Vec3f> (y, x) = cv::Vec3f (0.f, 0.f, -1.f);
      }
  };
  for (const bool vector : {false, true})
  {
    if (vector && !cpuHasAvx2Fma ())
      continue;
    const bool before = vectorKernelsEnabled ();
    setVectorKernelsEnabled (vector);
    SCOPED_TRACE (vector ? "vector kernels" : "scalar code");
    SegmentPropagation propagation;
    GlobalSegmentMap map;
    fill (0.9f);
    PropagationResult first, near, far;
    propagation.propagate (V, N, lj, Vm, Nm, none, map, 0, first);  // the model has no labels yet
    ASSERT_EQ (first.fresh, 1);
    const std::int32_t label = first.labels.at<std::int32_t> (0, 0);
    const cv::Mat model_labels (h, w, CV_32S, cv::Scalar (label));
    propagation.propagate (V, N, lj, Vm, Nm, model_labels, map, 1, near);
    EXPECT_EQ (near.inherited, 1);
    EXPECT_EQ (near.fresh, 0);
    EXPECT_EQ (cv::countNonZero (near.labels != label), 0);
    fill (5.f);
    propagation.propagate (V, N, lj, Vm, Nm, model_labels, map, 2, far);
    EXPECT_EQ (far.inherited, 0);
    EXPECT_EQ (far.fresh, 1);
    // A segment with frame normals over most of it keeps the reference's normal test for
    // every pixel: its 40 % without a normal agree in distance (more than inherit_overlap),
    // the rest turns across the model's normals; it takes a fresh label.
    fill (0.9f);
    for (int y = 0; y < 24; ++y)
      for (int x = 0; x < w; ++x)
        N.at<cv::Vec3f> (y, x) = cv::Vec3f (1.f, 0.f, 0.f);
    PropagationResult mixed;
    propagation.propagate (V, N, lj, Vm, Nm, model_labels, map, 3, mixed);
    EXPECT_EQ (mixed.inherited, 0);
    EXPECT_EQ (mixed.fresh, 1);
    setVectorKernelsEnabled (before);
  }
}

TEST (FragmentationReport, CountsSegmentsAndSurfaceBySize)
{
  // Sizes on both sides of each bound: 99 | 100, 999 | 1000, 9999 | 10000; one empty.
  std::vector<SegmentRecord> segments;
  for (const std::size_t voxels : {0, 5, 99, 100, 999, 1000, 9999, 10000, 20000})
  {
    SegmentRecord r;
    r.id = static_cast<std::uint32_t> (segments.size () + 1);
    r.voxels = voxels;
    segments.push_back (r);
  }
  const FragmentationReport f = fragmentationReport (segments);
  const double total = 5 + 99 + 100 + 999 + 1000 + 9999 + 10000 + 20000;
  EXPECT_EQ (f.segments, 8u);
  EXPECT_EQ (f.voxels, static_cast<std::size_t> (total));
  EXPECT_EQ (f.count_by_size, (std::array<std::size_t, 4>{2, 2, 2, 2}));
  EXPECT_EQ (f.segments_at_least_100 (), 6u);
  EXPECT_DOUBLE_EQ (f.shareBelow (100), 104 / total);
  EXPECT_DOUBLE_EQ (f.shareBelow (1000), (104 + 1099) / total);
  EXPECT_DOUBLE_EQ (f.shareBelow (10000), (104 + 1099 + 10999) / total);
  EXPECT_THROW (f.shareBelow (500), ParameterError);
  EXPECT_EQ (fragmentationReport ({}).segments, 0u);
  EXPECT_EQ (fragmentationReport ({}).shareBelow (100), 0.0);
}

TEST (SegmentsFile, WhatRunWritesEvalReadsBack)
{
  // Two segments: a mug voted in 4 of its 5 frames (score 3.2 summed) with points in the
  // map, and a 50-voxel splinter without a class or points.
  SegmentRecord mug, splinter;
  mug.id = 3;
  mug.first_frame = 2;
  mug.last_frame = 9;
  mug.frames_seen = 5;
  mug.voxels = 500;
  mug.class_votes["cup"] = {4, 3.2f};
  mug.bounds = Eigen::AlignedBox3f (Eigen::Vector3f (0.1f, 0.2f, 0.7f), Eigen::Vector3f (0.2f, 0.3f, 0.85f));
  splinter.id = 7;
  splinter.voxels = 50;
  ObjectGeometry geometry;
  geometry.points = 120;
  geometry.centroid = Eigen::Vector3f (0.15f, 0.25f, 0.78f);
  geometry.box.center = Eigen::Vector3f (0.15f, 0.25f, 0.775f);
  geometry.box.extents = Eigen::Vector3f (0.15f, 0.1f, 0.1f);
  const test::TempDir dir;
  const std::string path = dir / "segments.json";
  writeSegmentsJson (path, {mug, splinter}, {{3u, geometry}});

  const std::vector<SegmentEntry> read = readSegmentsJson (path);
  ASSERT_EQ (read.size (), 2u);
  EXPECT_EQ (read[0].id, 3u);
  EXPECT_EQ (read[0].class_name, "cup");
  EXPECT_NEAR (read[0].score, 0.8, 1e-6);  // the mean score of the frames that voted
  EXPECT_EQ (read[1].id, 7u);
  EXPECT_EQ (read[1].class_name, "");
  EXPECT_EQ (read[1].score, 0.0);  // the masks spoke in this run, never for it: ranked last

  // A run where no mask gave any segment a class (geometry): no scores at all.
  const std::string geometry_only = dir / "geometry.json";
  writeSegmentsJson (geometry_only, {splinter}, {});
  const std::vector<SegmentEntry> unscored = readSegmentsJson (geometry_only);
  ASSERT_EQ (unscored.size (), 1u);
  EXPECT_EQ (unscored[0].score, -1.0);

  const nlohmann::json doc = nlohmann::json::parse (test::readFile (path));
  const nlohmann::json& first = doc["segments"][0];
  EXPECT_EQ (first["voxels"], 500);
  EXPECT_EQ (first["frames_seen"], 5);
  EXPECT_EQ (first["class_votes"]["cup"], 4);
  EXPECT_EQ (first["points"], 120);
  EXPECT_NEAR (first["centroid"][2].get<double> (), 0.78, 1e-6);
  EXPECT_NEAR (first["oriented_box"]["extents"][0].get<double> (), 0.15, 1e-6);
  EXPECT_NEAR (first["bounds"]["max"][2].get<double> (), 0.85, 1e-6);
  const nlohmann::json& second = doc["segments"][1];
  EXPECT_EQ (second["points"], 0);
  EXPECT_TRUE (second["centroid"].is_null ());
  EXPECT_TRUE (second["class"].is_null ());
  EXPECT_EQ (doc["fragmentation"]["segments"], 2);
  EXPECT_EQ (doc["fragmentation"]["segments_at_least_100_voxels"], 1);
  EXPECT_NEAR (doc["fragmentation"]["share_of_surface_below_100_voxels"].get<double> (), 50.0 / 550.0, 1e-9);
}

TEST (ObjectGeometry, CentroidAndOrientedBoxOfRotatedBoxes)
{
  // Points on the faces of boxes of known size, turned and moved, with label 0 and NaN
  // points beside: each label's box has the box's sides (within the sampling step) along
  // its edges, largest first, and the centroid is the points' mean.
  std::mt19937 rng (40);
  pcl::PointCloud<pcl::PointXYZRGBL> map;
  struct Truth
  {
    Eigen::Vector3f size, centre;
    Eigen::Matrix3f rotation;
  };
  std::map<std::uint32_t, Truth> truth;
  const float step = 0.005f;
  for (std::uint32_t label : {3u, 9u})
  {
    Truth t;
    t.size = label == 3 ? Eigen::Vector3f (0.30f, 0.12f, 0.06f) : Eigen::Vector3f (0.08f, 0.20f, 0.45f);
    t.centre = Eigen::Vector3f (std::uniform_real_distribution<float> (-2.f, 2.f) (rng), 1.5f, 0.7f);
    t.rotation = (Eigen::AngleAxisf (std::uniform_real_distribution<float> (0.f, 3.f) (rng), Eigen::Vector3f (1, 2, 3).normalized ()))
                   .toRotationMatrix ();
    truth[label] = t;
    // A grid of about 5 mm on each face, corners included exactly.
    const Eigen::Vector3i cells = (t.size / step).array ().round ().cast<int> ();
    for (int i = 0; i <= cells.x (); ++i)
      for (int j = 0; j <= cells.y (); ++j)
        for (int k = 0; k <= cells.z (); ++k)
        {
          if (i != 0 && i != cells.x () && j != 0 && j != cells.y () && k != 0 && k != cells.z ())
            continue;  // inside
          const Eigen::Vector3f local = Eigen::Vector3f (static_cast<float> (i) / cells.x (), static_cast<float> (j) / cells.y (),
                                                         static_cast<float> (k) / cells.z ())
                                          .cwiseProduct (t.size) - 0.5f * t.size;
          pcl::PointXYZRGBL p;
          p.getVector3fMap () = t.rotation * local + t.centre;
          p.label = label;
          map.push_back (p);
        }
  }
  pcl::PointXYZRGBL stray;
  stray.getVector3fMap () = Eigen::Vector3f (50.f, 50.f, 50.f);
  stray.label = 0;
  map.push_back (stray);  // label 0: no object
  stray.x = std::numeric_limits<float>::quiet_NaN ();
  stray.label = 3;
  map.push_back (stray);  // no coordinates: left out
  const auto geometry = objectGeometry (map);
  ASSERT_EQ (geometry.size (), 2u);
  for (const auto& [label, t] : truth)
  {
    const ObjectGeometry& g = geometry.at (label);
    Eigen::Vector3d mean = Eigen::Vector3d::Zero ();
    std::size_t n = 0;
    for (const auto& p : map.points)
      if (p.label == label && std::isfinite (p.x))
      {
        mean += p.getVector3fMap ().cast<double> ();
        ++n;
      }
    EXPECT_EQ (g.points, n);
    EXPECT_LT ((g.centroid.cast<double> () - mean / static_cast<double> (n)).norm (), 1e-5) << label;
    EXPECT_LT ((g.box.center - t.centre).norm (), 1e-4f) << label;
    // The box's axes, sorted by the true sides (largest first), and the sides' lengths.
    std::vector<int> order = {0, 1, 2};
    std::sort (order.begin (), order.end (), [&] (int a, int b) { return t.size[a] > t.size[b]; });
    for (int k = 0; k < 3; ++k)
    {
      const Eigen::Vector3f edge = t.rotation.col (order[static_cast<std::size_t> (k)]);
      EXPECT_GT (std::abs (edge.dot (g.box.axes.col (k))), 0.999f) << label << " axis " << k;
      EXPECT_NEAR (g.box.extents[k], t.size[order[static_cast<std::size_t> (k)]], 1e-4f) << label << " axis " << k;
    }
    EXPECT_NEAR (g.box.axes.determinant (), 1.f, 1e-5f);  // right-handed
  }
}
