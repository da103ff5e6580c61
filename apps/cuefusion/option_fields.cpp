// SPDX-License-Identifier: BSD-3-Clause
#include "option_fields.h"

#include <cstring>
#include <stdexcept>

namespace cuefusion
{
namespace cli
{
namespace
{
struct OptionField
{
  const char* field;   ///< as the library's ParameterError names it: "Class::field", or an enum's type
  const char* option;  ///< as the user types it, without the dashes
};

/** Each option bound to a library Config field, once: the commands define their options
  * by it (boundOption) and main.cpp translates the library's errors by it
  * (optionOfParameter). A field without an option here reaches the user by its own name,
  * which settings files use. */
const OptionField kOptionFields[] = {
  {"InstanceGuidedRegionMergeConfig::min_overlap", "min-overlap"},
  {"PeriodicSegmenter::period", "masks-every"},
  {"InstanceGuidedRegionMergeConfig::color_split_distance", "color-split"},
  {"ConcavityEdgeEstimationConfig::noise_slope", "concavity-noise-slope"},
  {"ConcavityEdgeEstimationConfig::threshold", "concavity-threshold"},
  {"ConcavityEdgeEstimationConfig::neighbour_step", "concavity-step"},
  {"DepthDiscontinuityEdgeEstimationConfig::noise_factor", "noise-factor"},
  {"GeometricSegmentationConfig::noise_scale", "noise-scale"},
  {"DepthDiscontinuityEdgeEstimationConfig::neighbour_step", "depth-edge-step"},
  {"EdgeLabelingConfig::closing_iterations", "closings"},
  {"EdgeLabelingConfig::min_segment_size", "min-segment-size"},
  {"EdgeLabelingConfig::edge_assignment_radius", "edge-radius"},
  {"EdgeLabelingConfig::max_depth_jump", "max-depth-jump"},
  {"SurfacePreprocessingConfig::normals.step", "normal-step"},
  {"SurfacePreprocessingConfig::normals.max_depth_jump", "max-depth-jump"},
  {"SurfacePreprocessingConfig::integral_smoothing", "normal-smoothing"},
  {"SupportPlaneRemovalConfig::distance_threshold", "plane-distance"},
  {"SurfacePreprocessingConfig::bilateral.noise_range_sigma", "range-sigma"},
  {"SurfacePreprocessingConfig::bilateral.sigma_space", "sigma-space"},
  {"SurfacePreprocessingConfig::bilateral.diameter", "bilateral-diameter"},
  {"OnnxInstanceSegmenterConfig::input_size", "input-size"},
  {"OnnxInstanceSegmenterConfig::score_threshold", "score-threshold"},
  {"OnnxInstanceSegmenterConfig::boundary_threshold", "boundary-threshold"},
  {"RandomSceneConfig::min_objects", "min-objects/--max-objects"},
  {"RandomSceneConfig::touching_probability", "touching"},
  {"RandomSceneConfig::stacking_probability", "stacking"},
  {"RandomSceneConfig::multipart_probability", "multipart"},
  {"RandomSceneConfig::figure_probability", "figures"},
  {"RandomSceneConfig::aligned_probability", "aligned"},
  {"RandomSceneConfig::room_probability", "rooms"},
  {"RandomSceneConfig::table_probability", "table"},
  {"RandomSceneConfig::views_per_scene", "views-per-scene"},
  {"DetectorErrorConfig::merge_probability", "mask-merge"},
  {"DetectorErrorConfig::miss_probability", "mask-miss"},
  {"DetectorErrorConfig::split_probability", "mask-split"},
  {"DetectorErrorConfig::false_positives", "mask-false-positives"},
  {"DetectorErrorConfig::boundary_px", "mask-boundary"},
  {"DetectorErrorConfig::boundary_jitter_px", "mask-jitter"},
  {"DetectorErrorConfig::min_pixels", "mask-min-pixels"},
  {"SyntheticSequenceConfig::frames", "frames"},
  {"SyntheticSequenceConfig::fps", "fps"},
  {"SyntheticSequenceConfig::width", "size"},
  {"SyntheticSequenceConfig::gt_cloud_spacing", "gt-spacing"},
  {"SequenceFormat", "format"},
  {"DatasetLayout", "layout"},
  {"SegmentationMode", "mode"},
  {"TSDFVolumeConfig::voxel_size", "voxel"},
  {"TSDFVolumeConfig::truncation_voxels", "truncation"},
  {"TSDFVolumeConfig::max_depth", "max-depth"},
  {"DepthPreprocessorConfig::max_depth", "max-depth"},
  {"DenseReconstructionConfig::hole_refresh_period", "hole-refresh"},
  {"RunEvaluationConfig::every", "every"},
  {"FrameIoUConfig::min_truth_pixels", "min-pixels"},
  {"InstanceAPConfig::min_region_size", "min-region"},
  {"RunEvaluationConfig::match_radius", "match-radius"},
};
}  // namespace

const char*
boundOption (const char* field)
{
  for (const OptionField& b : kOptionFields)
    if (std::strcmp (b.field, field) == 0)
      return b.option;
  throw std::logic_error (std::string ("no command-line option is bound to ") + field);
}

std::string
optionOfParameter (const std::string& parameter)
{
  for (const OptionField& b : kOptionFields)
    if (parameter == b.field)
      return std::string ("--") + b.option;
  return std::string ();
}
}  // namespace cli
}  // namespace cuefusion
