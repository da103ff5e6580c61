// SPDX-License-Identifier: BSD-3-Clause
#pragma once

#include <cuefusion/common/instance.h>
#include <cuefusion/common/rgbd_frame.h>
#include <cuefusion/pipeline/mask_carry.h>
#include <cuefusion/reconstruction/dense_reconstruction.h>
#include <cuefusion/segmentation/geometric_segmentation.h>
#include <cuefusion/segmentation/global_segment_map.h>
#include <cuefusion/segmentation/instance_guided_region_merge.h>
#include <cuefusion/segmentation/segment_propagation.h>
#include <cuefusion/segmentation/surface_preprocessing.h>
#include <cuefusion/segmentation/voxel_label_layer.h>

#include <pcl/PolygonMesh.h>
#include <pcl/point_cloud.h>
#include <pcl/point_types.h>

#include <deque>
#include <optional>
#include <string>
#include <unordered_map>
#include <vector>

namespace cuefusion
{
namespace pipeline
{
/** \brief Which cues make the frame segments L_t. */
enum class SegmentationMode
{
  Fused,     ///< geometry cut and grouped by instance masks (InstanceGuidedRegionMerge::split, grouping in the map), the default
  Geometry,  ///< geometry only: the Tateno et al. 2015 baseline the thesis compares against
  Masks      ///< instance masks only (on pixels with depth)
};

/** \brief "fused", "geometry", "masks"; throws ParameterError naming --mode otherwise. */
SegmentationMode
parseSegmentationMode (const std::string& name);
std::string
segmentationModeName (SegmentationMode mode);

/** \brief Everything FusionPipeline runs with; each part keeps the reference's defaults. */
struct FusionPipelineConfig
{
  reconstruction::DenseReconstructionConfig reconstruction;
  /// The frame segmentation; its preprocessing (smoothing, holes, normals) is the
  /// pipeline's, shared with tracking (see share_smoothing). The pipeline always
  /// preprocesses: geometry.preprocess is read only by GeometricSegmentation on clouds
  /// given to it directly.
  segmentation::GeometricSegmentationConfig geometry;
  segmentation::InstanceGuidedRegionMergeConfig instance_merge;
  segmentation::SegmentPropagationConfig propagation;
  segmentation::GlobalSegmentMapConfig merging;
  segmentation::VoxelLabelUpdateConfig update;
  SegmentationMode mode = SegmentationMode::Fused;
  /** One depth smoothing and one normal map for tracking and segmentation (as in the
    * reference, where the segmentation reads the maps KinectFusion's preprocessing made):
    * tracking uses the segmentation's noise-adaptive bilateral filter (geometry.preprocessing's
    * diameter, range and spatial σ) and its normals (geometry.preprocessing.normals: ±4 px, for the
    * ICP's normal test at level 0 and the propagation), and the segmentation starts from
    * tracking's filtered depth and level-0 normals, computing neither again (normals only
    * on images at least 160 × geometry.preprocessing.normals.step pixels wide: see
    * reconstruction::DepthPreprocessorConfig::normals_min_width). Off: each
    * smooths the raw depth and computes normals its own way (tracking with
    * reconstruction.preprocessing's fixed range σ and ±1 px normals), one more filter and
    * one more normal map per frame.
    */
  bool share_smoothing = true;
  /** With geometry.noise_scale 0 (the default), the depth noise is measured on the first
    * this many frames with enough surface (reconstruction::estimateDepthNoise, from the raw
    * depth before any smoothing) and their median ratio, at least 1, is the scale of every
    * threshold written in sensor-noise units from then on: the smoothing's range σ shared
    * with tracking, the concavity's noise slopes and wide test's span, the depth-edge
    * factor (GeometricSegmentationConfig::noiseScaled), tracking's normal gate
    * (reconstruction::ProjectiveICPConfig::noise_scale), the propagation's distance
    * test (SegmentPropagationConfig::noise_factor) and the TSDF truncation, which is set
    * once, before the first frame is fused (reconstruction::DenseReconstruction::
    * setTruncation; the label update's band keeps its width in metres). Until the first
    * measurement the scale is 1.
    */
  int noise_estimation_frames = 10;
  void validate () const;
};

/** \brief Milliseconds of the segmentation stages of one frame. */
struct SegmentationTimings
{
  double geometry_ms = 0.0;     ///< preprocessing + L^G
  double instances_ms = 0.0;    ///< InstanceGuidedRegionMerge (or masks only)
  double propagation_ms = 0.0;
  double merging_ms = 0.0;
  double update_ms = 0.0;       ///< voxel labels
  double total () const { return geometry_ms + instances_ms + propagation_ms + merging_ms + update_ms; }
};

/** \brief What happened to one frame. */
struct PipelineFrameReport
{
  reconstruction::FrameReport reconstruction;
  bool segmented = false;        ///< false when the frame was not fused (tracking lost)
  float noise_scale = 1.f;       ///< the depth noise scale this frame ran with (FusionPipelineConfig::noise_estimation_frames)
  bool had_masks = false;
  int frame_segments = 0;        ///< labelled segments of L^p
  int fresh_segments = 0;
  std::size_t merges = 0;        ///< labels whose object changed this frame (merges made or undone)
  std::size_t voxel_writes = 0;
  SegmentationTimings segmentation;
  /** process() from call to return, wall clock: the whole loop of the frame. Not the sum
    * of the stages: the frame's segmentation (geometry_ms, instances_ms) runs beside its
    * tracking, integration and raycast. */
  double loop_ms = 0.0;
};

/** \brief The incremental pipeline of the thesis (chapter 3, §4.1–4.2), one frame at a
  * time: preprocess → track → integrate → raycast (DenseReconstruction) → geometric
  * segmentation (SurfacePreprocessing, GeometricSegmentation) → instance masks →
  * InstanceGuidedRegionMerge → SegmentPropagation → segment merging (GlobalSegmentMap) →
  * per-voxel label update. Frames are processed in the order given and deterministically;
  * whoever drives it (a grabber's callback in `cuefusion run`) passes each frame's masks,
  * or none (the frame is then segmented by geometry alone).
  */
class FusionPipeline
{
public:
  explicit FusionPipeline (const FusionPipelineConfig& config = FusionPipelineConfig ());
  const FusionPipelineConfig& getConfig () const { return config_; }

  /** \param[in] instances the frame's instance masks, nullptr when there are none */
  PipelineFrameReport process (const RGBDFrame& frame, const std::vector<Instance>* instances);

  /** \brief The same, with \a instances computed on the frame of index \a masks_frame (a
    * live camera's newest masks, `--masks-every`'s reused ones;
    * InstanceSegmenter::lastResultFrame): when that is an earlier frame the pipeline was
    * given this way and tracked, they are first carried into this frame by the camera's
    * motion from that frame's pose to this one's expected pose (carryMasks,
    * DenseReconstruction::expectedPose); else they are used as they are. Each tracked frame
    * given this way is remembered (its depth, camera and pose; the last kRememberedViews). */
  PipelineFrameReport process (const RGBDFrame& frame, const std::vector<Instance>* instances,
                               std::optional<std::size_t> masks_frame);

  /// Frames remembered for carrying masks: a live camera's masks are a few frames old.
  static constexpr std::size_t kRememberedViews = 8;

  /** \brief Continues a saved map (before the first frame; cuefusion::Error after it):
    * the reconstruction continues \a volume and \a keyframes
    * (DenseReconstruction::continueFrom: the first frame is relocalised in it), and each
    * label of \a labels (the volume's label layer, VoxelLabelLayer::load) becomes a segment
    * of the map (SegmentRecord::loaded), its voxels relabelled 1, 2, … in the order found.
    * Save with saveVolume(), whose labels are the outputs' (one per object), so a continued
    * map starts with the objects its outputs showed. Class votes and frame counts are not
    * saved: segments.json counts this run's.
    */
  void continueFrom (reconstruction::TSDFVolume volume, segmentation::VoxelLabelLayer labels,
                     reconstruction::KeyframeDatabase keyframes);

  /** \brief Writes the volume (TSDFVolume::save), its label layer with each voxel's label
    * as the outputs show it (labelledCloud; VoxelLabelLayer::save) and, when
    * \a keyframes_path is not empty, the relocalisation keyframes and the last fused frame
    * (DenseReconstruction::keyframesForContinuing, KeyframeDatabase::save): what
    * continueFrom reads back.
    */
  void saveVolume (const std::string& volume_path, const std::string& labels_path, const std::string& keyframes_path) const;

  const reconstruction::DenseReconstruction& reconstruction () const { return reconstruction_; }
  const segmentation::GlobalSegmentMap& segmentMap () const { return map_; }
  /** \brief The depth noise scale the thresholds follow now (geometry.noise_scale, or as
    * measured so far: FusionPipelineConfig::noise_estimation_frames).
    */
  float noiseScale () const { return noise_scale_; }
  /** \brief The label layer beside the volume (§4.2.4): each voxel's label (as stored, not
    * resolved) and confidence Ψ.
    */
  const segmentation::VoxelLabelLayer& voxelLabels () const { return *labels_; }
  /** \brief The last frame's L^p (global labels), empty before the first segmented frame. */
  const cv::Mat& frameLabels () const { return frame_labels_; }
  /** \brief The model's labels seen from the last pose, as outputs show them (CV_32S). */
  cv::Mat modelLabels () const;

  /** \brief Surface points (world frame) with colour and segment label as outputs show
    * them: each label resolved to its object, brief fragments settled into the object they
    * touch (GlobalSegmentMap::settledLabels). Coloured by the fused colour, or by segment
    * (segmentColor) when \a color_by_segment.
    */
  pcl::PointCloud<pcl::PointXYZRGBL>::Ptr labelledCloud (bool color_by_segment = false) const;
  /** \brief Marching-cubes mesh with labels as labelledCloud's, vertices coloured by
    * segment (segmentColor) when \a color_by_segment, else by the fused colour.
    * io::writeMeshPLY writes it.
    */
  TriangleMesh labelledTriangleMesh (bool color_by_segment = true) const;
  /** \brief labelledTriangleMesh as a pcl::PolygonMesh (io::toPolygonMesh). */
  pcl::PolygonMesh labelledMesh (bool color_by_segment = true) const;
  /** \brief Refreshes and returns the records of the segments outputs show (voxel counts,
    * bounds; settled fragments counted with their object).
    */
  std::vector<segmentation::SegmentRecord> segments ();

private:
  FusionPipelineConfig config_;
  reconstruction::DenseReconstruction reconstruction_;
  segmentation::GeometricSegmentation<pcl::PointXYZ, pcl::Normal> geometry_;
  segmentation::InstanceGuidedRegionMerge instance_merge_;
  segmentation::SegmentPropagation propagation_;
  segmentation::GlobalSegmentMap map_;
  /** On the heap, so that its address, which the model raycast samples (setModelValues,
    * set once), stays when the pipeline is moved. */
  std::unique_ptr<segmentation::VoxelLabelLayer> labels_ = std::make_unique<segmentation::VoxelLabelLayer> ();
  segmentation::SurfacePlanes planes_;
  cv::Mat frame_labels_;
  std::deque<std::pair<std::size_t, MaskView>> mask_views_;  ///< by frame index, oldest first (process with masks_frame)
  /** \brief The output label of \a label (GlobalSegmentMap::settledLabels). Exact for
    * the written outputs; for per-frame views (\a exact false) the table may be up to
    * kViewSettleFrames frames old (it scans the whole volume), and labels made since show
    * as their object.
    */
  std::uint32_t settledLabel (std::uint32_t label, bool exact) const;
  /** \brief L^G (§4.2.1.1) and L_t (§4.2.1.3) of \a frame into \a frame_segments and
    * \a info, timed into \a timings: the work on the frame alone, which process() runs
    * beside tracking, integration and the raycast (DenseReconstruction::process). Reads
    * the frame's pyramid level 0 (sharedMaps().frame) and writes only planes_, geometry_
    * and instance_merge_ of this object.
    */
  void segmentFrame (const RGBDFrame& frame, const std::vector<Instance>* instances, cv::Mat& frame_segments,
                     std::vector<segmentation::SegmentInstance>& info, SegmentationTimings& timings);
  void refreshSettled (bool exact) const;
  /** \brief Measures the noise of \a frame while the estimate is open and, when the scale
    * changes, gives the stages their thresholds at the new scale.
    */
  void followNoise (const RGBDFrame& frame);
  /** \brief The stages' noise thresholds at \a scale (config_'s times \a scale). */
  void applyNoiseScale (float scale);
  float noise_scale_ = 1.f;
  std::vector<float> noise_ratios_;  ///< the frames' measured ratios so far
  /** The label update (config_.update with its band in the configured truncation's metres:
    * the volume's truncation follows the noise, the band of voxels a frame's labels reach
    * does not — measured on generated rooms through the RealSense-like sensor, a band of
    * the noise-scaled truncation joined books on shelves and thin objects to what lies
    * behind them). */
  segmentation::VoxelLabelUpdateConfig update_;
  static constexpr std::size_t kViewSettleFrames = 30;
  std::size_t processed_ = 0;  ///< frames given to process()
  mutable std::size_t settled_at_ = static_cast<std::size_t> (-1);
  mutable std::uint32_t settled_end_ = 0;  ///< labels below this existed when settled_ was made
  mutable std::unordered_map<std::uint32_t, std::uint32_t> settled_;
};
}  // namespace pipeline
}  // namespace cuefusion
