// SPDX-License-Identifier: BSD-3-Clause
// Settings files (io/settings_json.h): the field lists of the pipeline's Configs, each
// field under its name in the struct. A field added to one of these Configs is added
// here too, or settings files and outputs.json cannot set or record it.
#include <cuefusion/pipeline/settings.h>

#include <cuefusion/common/exceptions.h>
#include <cuefusion/io/settings_json.h>

namespace cuefusion
{
namespace reconstruction
{
template <class V>
void
fields (V& v, TSDFVolumeConfig& c)
{
  v ("voxel_size", c.voxel_size);
  v ("truncation_voxels", c.truncation_voxels);
  v ("max_weight", c.max_weight);
  v ("min_depth", c.min_depth);
  v ("max_depth", c.max_depth);
  v ("bounds", c.bounds);
}

template <class V>
void
fields (V& v, BilateralFilterConfig& c)
{
  v ("enabled", c.enabled);
  v ("diameter", c.diameter);
  v ("sigma_space", c.sigma_space);
  v ("noise_range_sigma", c.noise_range_sigma);
  v ("range_sigma_metres", c.range_sigma_metres);
}

template <class V>
void
fields (V& v, NormalMapConfig& c)
{
  v ("step", c.step);
  v ("max_depth_jump", c.max_depth_jump);
}

template <class V>
void
fields (V& v, DepthPreprocessorConfig& c)
{
  v ("bilateral", c.bilateral);
  v ("pyramid_levels", c.pyramid_levels);
  v ("min_depth", c.min_depth);
  v ("max_depth", c.max_depth);
  v ("max_depth_jump", c.max_depth_jump);
  v ("normals", c.normals);
  v ("normals_min_width", c.normals_min_width);
}

template <class V>
void
fields (V& v, ProjectiveICPConfig& c)
{
  v ("iterations", c.iterations);
  v ("max_distance", c.max_distance);
  v ("max_angle_deg", c.max_angle_deg);
  v ("angle_reference_depth", c.angle_reference_depth);
  v ("max_angle_limit_deg", c.max_angle_limit_deg);
  v ("noise_scale", c.noise_scale);
  v ("convergence_translation", c.convergence_translation);
  v ("convergence_rotation", c.convergence_rotation);
  v ("noise_weighting", c.noise_weighting);
}

template <class V>
void
fields (V& v, CameraTrackerConfig& c)
{
  v ("icp", c.icp);
  v ("min_inlier_fraction", c.min_inlier_fraction);
  v ("min_inliers", c.min_inliers);
  v ("max_rmse", c.max_rmse);
  v ("min_translation_conditioning", c.min_translation_conditioning);
  v ("max_translation", c.max_translation);
  v ("max_rotation_deg", c.max_rotation_deg);
}

template <class V>
void
fields (V& v, KeyframeDatabaseConfig& c)
{
  v ("ferns", c.ferns);
  v ("decisions", c.decisions);
  v ("size", c.size);
  v ("max_depth", c.max_depth);
  v ("min_novelty", c.min_novelty);
  v ("max_keyframes", c.max_keyframes);
  v ("seed", c.seed);
}

template <class V>
void
fields (V& v, FeatureRelocaliserConfig& c)
{
  v ("features", c.features);
  v ("scale_factor", c.scale_factor);
  v ("levels", c.levels);
  v ("ratio", c.ratio);
  v ("ransac_iterations", c.ransac_iterations);
  v ("inlier_distance", c.inlier_distance);
  v ("min_inliers", c.min_inliers);
  v ("max_views", c.max_views);
  v ("wide_features", c.wide_features);
  v ("seed", c.seed);
}

template <class V>
void
fields (V& v, DenseReconstructionConfig& c)
{
  v ("volume", c.volume);
  v ("preprocessing", c.preprocessing);
  v ("tracking", c.tracking);
  v ("use_reference_poses", c.use_reference_poses);
  v ("hole_refresh_period", c.hole_refresh_period);
  v ("relocalise", c.relocalise);
  v ("keyframes", c.keyframes);
  v ("keyframe_period", c.keyframe_period);
  v ("relocalisation_candidates", c.relocalisation_candidates);
  v ("relocalisation_min_inlier_fraction", c.relocalisation_min_inlier_fraction);
  v ("relocalisation_min_agreement", c.relocalisation_min_agreement);
  v ("relocalisation_min_overlap", c.relocalisation_min_overlap);
  v ("relocalisation_confirmation_shift", c.relocalisation_confirmation_shift);
  v ("relocalisation_confirmation_deg", c.relocalisation_confirmation_deg);
  v ("relocalisation_min_texture_agreement", c.relocalisation_min_texture_agreement);
  v ("min_inlier_share_ratio", c.min_inlier_share_ratio);
  v ("motion_model", c.motion_model);
  v ("max_prediction_gap", c.max_prediction_gap);
  v ("relocalisation_candidates_per_frame", c.relocalisation_candidates_per_frame);
  v ("feature_relocalisation", c.feature_relocalisation);
  v ("features", c.features);
}
}  // namespace reconstruction

namespace segmentation
{
template <class V>
void
fields (V& v, SurfacePreprocessingConfig& c)
{
  v ("bilateral", c.bilateral);
  v.choice ("normal_method", c.normal_method,
            {{"central", NormalMethod::CentralDifference}, {"integral", NormalMethod::IntegralImage}});
  v ("normals", c.normals);
  v ("integral_smoothing", c.integral_smoothing);
  v ("max_hole_pixels", c.max_hole_pixels);
}

template <class V>
void
fields (V& v, ConcavityEdgeEstimationConfig& c)
{
  v.choice ("convexity_test", c.convexity_test,
            {{"divergence", ConvexityTest::NormalDivergence}, {"tangent", ConvexityTest::TangentPlane}});
  v ("threshold", c.threshold);
  v ("neighbour_step", c.neighbour_step);
  v ("noise_slope", c.noise_slope);
  v ("wide_step", c.wide_step);
  v ("wide_noise_slope", c.wide_noise_slope);
  v ("wide_noise_scale", c.wide_noise_scale);
}

template <class V>
void
fields (V& v, DepthDiscontinuityEdgeEstimationConfig& c)
{
  v ("noise_factor", c.noise_factor);
  v ("neighbour_step", c.neighbour_step);
}

template <class V>
void
fields (V& v, EdgeLabelingConfig& c)
{
  v ("closing_iterations", c.closing_iterations);
  v ("min_segment_size", c.min_segment_size);
  v ("edge_assignment_radius", c.edge_assignment_radius);
  v ("max_depth_jump", c.max_depth_jump);
}

template <class V>
void
fields (V& v, GeometricSegmentationConfig& c)
{
  v ("preprocess", c.preprocess);
  v ("preprocessing", c.preprocessing);
  v ("use_concavity_edges", c.use_concavity_edges);
  v ("use_discontinuity_edges", c.use_discontinuity_edges);
  v ("concavity", c.concavity);
  v ("discontinuity", c.discontinuity);
  v ("labeling", c.labeling);
  v ("noise_scale", c.noise_scale);
}

template <class V>
void
fields (V& v, InstanceGuidedRegionMergeConfig& c)
{
  v ("min_overlap", c.min_overlap);
  v ("split_share", c.split_share);
  v ("split_min_pixels", c.split_min_pixels);
  v ("occlusion_split_share", c.occlusion_split_share);
  v ("mask_boundary_tolerance", c.mask_boundary_tolerance);
  v ("color_split_distance", c.color_split_distance);
  v ("color_split_share", c.color_split_share);
  v ("max_depth_jump", c.max_depth_jump);
  v ("rim_max_normal_angle_deg", c.rim_max_normal_angle_deg);
  v ("noise_ratio", c.noise_ratio);
}

template <class V>
void
fields (V& v, SegmentPropagationConfig& c)
{
  v ("normal_agreement", c.normal_agreement);
  v ("inherit_overlap", c.inherit_overlap);
  v ("noise_factor", c.noise_factor);
  v ("min_segment_size", c.min_segment_size);
  v ("placement_share", c.placement_share);
  v ("uncovered_overlap", c.uncovered_overlap);
  v ("model_edge_share", c.model_edge_share);
}

template <class V>
void
fields (V& v, VoxelLabelUpdateConfig& c)
{
  v ("max_confidence", c.max_confidence);
  v ("band", c.band);
}

template <class V>
void
fields (V& v, GlobalSegmentMapConfig& c)
{
  v ("confirm_confidence", c.confirm_confidence);
  v ("together_share", c.together_share);
  v ("confirm_share", c.confirm_share);
  v ("surface_min_extent", c.surface_min_extent);
  v ("surface_tolerance", c.surface_tolerance);
  v ("surface_max_angle_deg", c.surface_max_angle_deg);
}

template <class V>
void
fields (V& v, SupportPlaneRemovalConfig& c)
{
  v ("distance_threshold", c.distance_threshold);
  v ("max_iterations", c.max_iterations);
  v ("sample_step", c.sample_step);
  v ("min_plane_fraction", c.min_plane_fraction);
  v ("min_segment_inlier_fraction", c.min_segment_inlier_fraction);
  v ("max_normal_angle_deg", c.max_normal_angle_deg);
}
}  // namespace segmentation

namespace pipeline
{
template <class V>
void
fields (V& v, FusionPipelineConfig& c)
{
  v.choice ("mode", c.mode,
            {{"fused", SegmentationMode::Fused}, {"geometry", SegmentationMode::Geometry}, {"masks", SegmentationMode::Masks}});
  v ("reconstruction", c.reconstruction);
  v ("geometry", c.geometry);
  v ("instance_merge", c.instance_merge);
  v ("propagation", c.propagation);
  v ("merging", c.merging);
  v ("update", c.update);
  v ("share_smoothing", c.share_smoothing);
  v ("noise_estimation_frames", c.noise_estimation_frames);
}

namespace
{
/** Reads \a json into a copy of \a config, checks it with its validate() (a
  * ParameterError then names the file's place and the field) and only then replaces
  * \a config: a bad file changes nothing. */
template <class Config>
void
readChecked (const nlohmann::json& json, Config& config, const std::string& path)
{
  Config read = config;
  io::readSettings (json, read, path);
  try
  {
    read.validate ();
  }
  catch (const ParameterError& e)
  {
    throw ParameterError (path + " (" + e.parameter () + ")", e.reason ());
  }
  config = std::move (read);
}
}  // namespace

nlohmann::json configJson (const FusionPipelineConfig& config) { return io::settingsJson (config); }
nlohmann::json configJson (const segmentation::GeometricSegmentationConfig& config) { return io::settingsJson (config); }
nlohmann::json configJson (const segmentation::InstanceGuidedRegionMergeConfig& config) { return io::settingsJson (config); }
nlohmann::json configJson (const segmentation::SupportPlaneRemovalConfig& config) { return io::settingsJson (config); }

void
readConfig (const nlohmann::json& json, FusionPipelineConfig& config, const std::string& path)
{
  readChecked (json, config, path);
}

void
readConfig (const nlohmann::json& json, segmentation::GeometricSegmentationConfig& config, const std::string& path)
{
  readChecked (json, config, path);
}

void
readConfig (const nlohmann::json& json, segmentation::InstanceGuidedRegionMergeConfig& config, const std::string& path)
{
  readChecked (json, config, path);
}

void
readConfig (const nlohmann::json& json, segmentation::SupportPlaneRemovalConfig& config, const std::string& path)
{
  readChecked (json, config, path);
}
}  // namespace pipeline
}  // namespace cuefusion
