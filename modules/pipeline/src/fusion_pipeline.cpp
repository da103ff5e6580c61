// SPDX-License-Identifier: BSD-3-Clause
#include <cuefusion/common/exceptions.h>
#include <cuefusion/common/label_colors.h>
#include <cuefusion/io/mesh_io.h>
#include <cuefusion/pipeline/fusion_pipeline.h>
#include <cuefusion/reconstruction/noise_estimation.h>

#include <pcl/common/time.h>

#include <algorithm>
#include <cstring>
#include <set>

namespace cuefusion
{
namespace pipeline
{
SegmentationMode
parseSegmentationMode (const std::string& name)
{
  if (name == "fused")
    return SegmentationMode::Fused;
  if (name == "geometry")
    return SegmentationMode::Geometry;
  if (name == "masks")
    return SegmentationMode::Masks;
  throw ParameterError ("SegmentationMode", "must be fused, geometry or masks, not '" + name + "'");
}

std::string
segmentationModeName (SegmentationMode mode)
{
  switch (mode)
  {
    case SegmentationMode::Fused:
      return "fused";
    case SegmentationMode::Geometry:
      return "geometry";
    case SegmentationMode::Masks:
      return "masks";
  }
  return "fused";
}

void
FusionPipelineConfig::validate () const
{
  reconstruction.validate ();
  geometry.validate ();
  instance_merge.validate ();
  propagation.validate ();
  merging.validate ();
  update.validate ();
  if (noise_estimation_frames < 0)
    throw ParameterError ("FusionPipelineConfig::noise_estimation_frames", "must not be negative");
}

namespace
{
/** \brief Whether tracking's level 0 serves the segmentation (FusionPipelineConfig::share_smoothing). */
bool
sharesSmoothing (const FusionPipelineConfig& config)
{
  return config.share_smoothing && config.geometry.preprocessing.bilateral.enabled;
}

/** \brief And its normal map too (the segmentation's normals are central differences). */
bool
sharesNormals (const FusionPipelineConfig& config)
{
  return sharesSmoothing (config) && config.geometry.preprocessing.normal_method == segmentation::NormalMethod::CentralDifference;
}

/** \brief The reconstruction's configuration, with the segmentation's smoothing and normals
  * where they are shared.
  */
reconstruction::DenseReconstructionConfig
reconstructionConfig (const FusionPipelineConfig& config, float noise_scale)
{
  reconstruction::DenseReconstructionConfig out = config.reconstruction;
  out.tracking.icp.noise_scale *= noise_scale;  // the normal gate follows the noise
  // and so does the truncation (set while nothing is fused: DenseReconstruction::setTruncation)
  out.volume.truncation_voxels =
      std::min (reconstruction::TSDFVolumeConfig::kMaxTruncationVoxels, out.volume.truncation_voxels * std::max (1.f, noise_scale));
  if (sharesSmoothing (config))
    out.preprocessing.bilateral = config.geometry.noiseScaled (noise_scale).preprocessing.bilateral;
  if (sharesNormals (config))
  {
    out.preprocessing.normals = config.geometry.preprocessing.normals;
    out.preprocessing.normals_min_width = 160 * config.geometry.preprocessing.normals.step;
  }
  return out;
}
}  // namespace

FusionPipeline::FusionPipeline (const FusionPipelineConfig& config)
  : config_ (config)
  , reconstruction_ (reconstructionConfig (config, 1.f))
  , geometry_ (config.geometry)
  , instance_merge_ (config.instance_merge)
  , propagation_ (config.propagation)
  , map_ (config.merging)
  , update_ (config.update)
{
  config_.validate ();
  // Until the noise is measured (or as configured), the thresholds' own scale.
  noise_scale_ = config_.geometry.scaleFor (1.f);
  if (noise_scale_ != 1.f)
  {
    const float scale = noise_scale_;
    noise_scale_ = 1.f;
    applyNoiseScale (scale);
  }
  // The label update (§4.2.4) reads the voxels each integration saw in the band.
  reconstruction_.volume ().setRecordObservedSurface (true);
  // The model raycast samples the labels (L^m of §4.2.2.1).
  reconstruction_.setModelValues (&labels_->labelValues ());
}

void
FusionPipeline::continueFrom (reconstruction::TSDFVolume volume, segmentation::VoxelLabelLayer labels,
                              reconstruction::KeyframeDatabase keyframes)
{
  if (processed_ > 0)
    throw Error ("FusionPipeline::continueFrom", "must come before the first frame");
  if (labels.blockCount () > volume.blockCount ())
    throw Error ("FusionPipeline::continueFrom", "the label layer has more blocks than the volume");
  // Each saved label becomes a segment of this map; the voxels take its new label.
  std::unordered_map<std::uint32_t, std::uint32_t> adopted;
  for (std::size_t id = 0; id < labels.blockCount (); ++id)
    for (std::uint32_t& label : labels.block (id).labels)
      if (label != 0)
      {
        const auto [it, fresh] = adopted.try_emplace (label, 0u);
        if (fresh)
          it->second = map_.newLoadedSegment (0);
        label = it->second;
      }
  *labels_ = std::move (labels);  // keeps labelValues ()'s address
  reconstruction_.continueFrom (std::move (volume), std::move (keyframes));
  update_ = config_.update;  // the loaded volume keeps its truncation, the band its share of it
  settled_at_ = static_cast<std::size_t> (-1);
}

void
FusionPipeline::saveVolume (const std::string& volume_path, const std::string& labels_path,
                            const std::string& keyframes_path) const
{
  refreshSettled (true);
  reconstruction_.volume ().save (volume_path);
  labels_->save (labels_path, reconstruction_.volume (), [this] (std::uint32_t label) { return settledLabel (label, true); });
  if (!keyframes_path.empty ())
    reconstruction_.keyframesForContinuing ().save (keyframes_path, reconstruction_.volume ());
}

void
FusionPipeline::applyNoiseScale (float scale)
{
  if (scale == noise_scale_)
    return;
  noise_scale_ = scale;
  const reconstruction::DenseReconstructionConfig reconstruction = reconstructionConfig (config_, scale);
  reconstruction_.setPreprocessingConfig (reconstruction.preprocessing);
  reconstruction_.setTrackingConfig (reconstruction.tracking);
  if (reconstruction_.setTruncation (reconstruction.volume.truncation_voxels))
  {
    update_ = config_.update;
    update_.band = static_cast<float> (update_.band * config_.reconstruction.volume.truncation_voxels /
                                       reconstruction.volume.truncation_voxels);
  }
  segmentation::GeometricSegmentationConfig geometry = config_.geometry;
  geometry.noise_scale = scale;
  geometry_.setConfig (geometry);
  segmentation::SegmentPropagationConfig propagation = config_.propagation;
  propagation.noise_factor *= scale;
  propagation_ = segmentation::SegmentPropagation (propagation);
}

void
FusionPipeline::followNoise (const RGBDFrame& frame)
{
  if (!config_.geometry.measuresNoise () ||
      noise_ratios_.size () >= static_cast<std::size_t> (config_.noise_estimation_frames))
    return;
  // A frame showing little surface (a blackout, a far wall half out of range) is not
  // measured: a hundred 8 × 8 patches are 2 % of a 640 × 480 image, 8 % of 320 × 240.
  constexpr int kMinPatches = 100;
  const reconstruction::DepthNoiseEstimate estimate = reconstruction::estimateDepthNoise (frame.depth);
  if (estimate.patches < kMinPatches)
    return;
  noise_ratios_.push_back (estimate.ratio);
  std::vector<float> ratios = noise_ratios_;
  const auto middle = ratios.begin () + static_cast<std::ptrdiff_t> (ratios.size () / 2);
  std::nth_element (ratios.begin (), middle, ratios.end ());
  applyNoiseScale (config_.geometry.scaleFor (*middle));
  segmentation::InstanceGuidedRegionMergeConfig merge = config_.instance_merge;
  merge.noise_ratio = *middle;  // where the rim's normal test applies
  instance_merge_ = segmentation::InstanceGuidedRegionMerge (merge);
}

void
FusionPipeline::segmentFrame (const RGBDFrame& frame, const std::vector<Instance>* instances, cv::Mat& frame_segments,
                              std::vector<segmentation::SegmentInstance>& info, SegmentationTimings& timings)
{
  pcl::StopWatch watch;
  // L^G from the frame's depth (§4.2.1.1).
  const PinholeCamera& camera = frame.camera;
  const reconstruction::DenseReconstruction::SharedMaps shared = reconstruction_.sharedMaps ();
  const reconstruction::PyramidLevel& level = shared.frame;
  if (sharesSmoothing (config_))
  {
    // Tracking's level 0 is this frame's depth through the same filter (0 = invalid), and
    // its normals are the segmentation's (same formula, span and edge test).
    planes_.assignDepth (level.depth, camera.fx, camera.fy, camera.cx, camera.cy);
    // (On images too small for tracking to use the segmentation's span, level 0 has ±1 px
    // normals, and the segmentation computes its own.)
    if (sharesNormals (config_) && shared.configured_normals)
    {
      planes_.assignNormals (level.normals);
      // Tracking keeps the sensor's holes; the segmentation fills the small ones inside a
      // surface (SurfacePreprocessingConfig::max_hole_pixels) with the normals around them.
      segmentation::fillSmallHoles (planes_, config_.geometry.preprocessing.max_hole_pixels,
                                    config_.geometry.preprocessing.normals.max_depth_jump, true);
    }
    else
    {
      segmentation::SurfacePreprocessingConfig normals_only = config_.geometry.preprocessing;
      normals_only.bilateral.enabled = false;
      segmentation::preprocessPlanes (planes_, normals_only);
    }
  }
  else
  {
    planes_.assignDepth (frame.depth, camera.fx, camera.fy, camera.cx, camera.cy);
    segmentation::preprocessPlanes (planes_, config_.geometry.noiseScaled (noise_scale_).preprocessing);
  }
  geometry_.segment (planes_);
  timings.geometry_ms = watch.getTime ();

  // L_t: geometry, grouped by the masks, or the masks alone (§4.2.1.3).
  watch.reset ();
  if (config_.mode == SegmentationMode::Geometry || (config_.mode == SegmentationMode::Fused && !instances))
    frame_segments = geometry_.getLabelImage ();
  else if (config_.mode == SegmentationMode::Fused)
    // Pieces: geometry cut where the masks see two objects; which pieces form one object
    // is the map's decision over frames (the masks' grouping goes in as evidence).
    instance_merge_.split (geometry_.getLabelImage (), *instances, frame_segments, &info, &planes_, frame.color);
  else
    segmentation::masksAsSegments (instances ? *instances : std::vector<Instance> (), planes_, frame_segments, &info);
  timings.instances_ms = watch.getTime ();
}

PipelineFrameReport
FusionPipeline::process (const RGBDFrame& frame, const std::vector<Instance>* instances, std::optional<std::size_t> masks_frame)
{
  if (!masks_frame)
    return process (frame, instances);
  // Masks of an earlier frame: carried into this one by the motion between the two.
  std::vector<Instance> carried;
  // The newest view of that index (a source that starts a sequence again repeats indices).
  const auto from = std::find_if (mask_views_.rbegin (), mask_views_.rend (), [&] (const auto& seen) { return seen.first == *masks_frame; });
  std::optional<Eigen::Isometry3d> expected;  // asked only when there are masks to carry
  if (instances && *masks_frame != frame.index && from != mask_views_.rend ())
    expected = reconstruction_.expectedPose (frame);
  const bool carry = expected.has_value ();
  if (carry)
    carried = carryMasks (*instances, from->second, MaskView{frame.depth, frame.camera, *expected});
  PipelineFrameReport report = process (frame, carry ? &carried : instances);
  if (report.reconstruction.tracked)
  {
    // A live grabber may reuse its buffers: the depth is copied.
    mask_views_.emplace_back (frame.index, MaskView{frame.depth.clone (), frame.camera, report.reconstruction.pose});
    if (mask_views_.size () > kRememberedViews)
      mask_views_.pop_front ();
  }
  return report;
}

PipelineFrameReport
FusionPipeline::process (const RGBDFrame& frame, const std::vector<Instance>* instances)
{
  pcl::StopWatch loop;
  PipelineFrameReport report;
  ++processed_;
  followNoise (frame);
  report.noise_scale = noise_scale_;
  report.had_masks = instances != nullptr;
  // L^G and L_t need the frame alone (its filtered depth and normals), not its pose: they
  // run beside tracking, integration and the raycast, on the second core that those
  // leave idle in their serial parts. The same computations on the same inputs: outputs
  // are those of one after the other. A lost frame's segmentation is not used.
  cv::Mat frame_segments;
  std::vector<segmentation::SegmentInstance> info;
  report.reconstruction = reconstruction_.process (
      frame, [&] { segmentFrame (frame, instances, frame_segments, info, report.segmentation); });
  if (!report.reconstruction.tracked)
  {
    report.segmentation = SegmentationTimings ();
    report.loop_ms = loop.getTime ();
    return report;
  }
  report.segmented = true;
  const reconstruction::DenseReconstruction::SharedMaps shared = reconstruction_.sharedMaps ();
  const reconstruction::PyramidLevel& level = shared.frame;
  pcl::StopWatch watch;

  // L^p against the model seen from the fused pose (§4.2.2).
  const reconstruction::RaycastResult& model = shared.model;
  segmentation::PropagationResult propagated;
  propagation_.propagate (level.vertices, level.normals, frame_segments, model.vertices, model.normals, model.values, map_,
                          frame.index, propagated, info.empty () ? nullptr : &info);
  frame_labels_ = propagated.labels;
  report.fresh_segments = propagated.fresh;
  report.frame_segments = propagated.inherited + propagated.fresh;
  report.segmentation.propagation_ms = watch.getTime ();

  // Grouping from the evidence of all frames so far (§4.2.3), then the voxel labels (§4.2.4).
  watch.reset ();
  report.merges = map_.addEvidence (propagated.votes);
  report.segmentation.merging_ms = watch.getTime ();
  watch.reset ();
  report.voxel_writes =
      segmentation::updateVoxelLabels (reconstruction_.volume (), *labels_, propagated.labels, map_, update_);
  report.segmentation.update_ms = watch.getTime ();
  report.loop_ms = loop.getTime ();
  return report;
}

void
FusionPipeline::refreshSettled (bool exact) const
{
  const bool stale = settled_at_ == static_cast<std::size_t> (-1) ||
                     (exact ? settled_at_ != processed_ : processed_ - settled_at_ >= kViewSettleFrames);
  if (!stale)
    return;
  settled_ = map_.settledLabels (reconstruction_.volume (), *labels_);
  settled_at_ = processed_;
  settled_end_ = static_cast<std::uint32_t> (map_.labelsAllocated () + 1);
}

std::uint32_t
FusionPipeline::settledLabel (std::uint32_t label, bool exact) const
{
  if (label == 0)
    return 0;
  if (!exact && label >= settled_end_)
    return map_.resolve (label);
  const auto it = settled_.find (label);
  return it == settled_.end () ? 0 : it->second;
}

cv::Mat
FusionPipeline::modelLabels () const
{
  const cv::Mat& labels = reconstruction_.model ().values;
  if (labels.empty ())
    return cv::Mat ();
  refreshSettled (false);
  cv::Mat out (labels.size (), CV_32S);
  for (int y = 0; y < labels.rows; ++y)
    for (int x = 0; x < labels.cols; ++x)
    {
      const std::int32_t l = labels.at<std::int32_t> (y, x);
      out.at<std::int32_t> (y, x) = l > 0 ? static_cast<std::int32_t> (settledLabel (static_cast<std::uint32_t> (l), false)) : 0;
    }
  return out;
}

pcl::PointCloud<pcl::PointXYZRGBL>::Ptr
FusionPipeline::labelledCloud (bool color_by_segment) const
{
  pcl::PointCloud<pcl::PointXYZRGBL>::Ptr cloud = pcl::make_shared<pcl::PointCloud<pcl::PointXYZRGBL>> ();
  refreshSettled (true);
  reconstruction_.volume ().extractPointCloud (*cloud, nullptr, [this] (reconstruction::VoxelNumber v) {
    return settledLabel (labels_->label (v), true);
  });
  if (color_by_segment)
    for (pcl::PointXYZRGBL& p : *cloud)
    {
      const cv::Vec3b rgb = segmentColor (p.label);
      p.r = rgb[0];
      p.g = rgb[1];
      p.b = rgb[2];
    }
  return cloud;
}

TriangleMesh
FusionPipeline::labelledTriangleMesh (bool color_by_segment) const
{
  refreshSettled (true);
  TriangleMesh mesh = reconstruction_.volume ().extractTriangleMesh (
      [this] (reconstruction::VoxelNumber v) { return settledLabel (labels_->label (v), true); });
  for (std::size_t i = 0; i < mesh.labels.size (); ++i)
  {
    if (color_by_segment)
    {
      const cv::Vec3b rgb = segmentColor (mesh.labels[i]);
      mesh.colors[i] = {rgb[0], rgb[1], rgb[2]};
    }
  }
  return mesh;
}

pcl::PolygonMesh
FusionPipeline::labelledMesh (bool color_by_segment) const
{
  return io::toPolygonMesh (labelledTriangleMesh (color_by_segment));
}

std::vector<segmentation::SegmentRecord>
FusionPipeline::segments ()
{
  map_.refreshStatistics (reconstruction_.volume (), *labels_);
  refreshSettled (true);
  std::vector<segmentation::SegmentRecord> all = map_.segments (&settled_), kept;
  for (auto& s : all)
    if (s.voxels > 0)
      kept.push_back (std::move (s));
  return kept;
}
}  // namespace pipeline
}  // namespace cuefusion
