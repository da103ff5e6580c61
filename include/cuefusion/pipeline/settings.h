// SPDX-License-Identifier: BSD-3-Clause
#pragma once

#include <cuefusion/pipeline/fusion_pipeline.h>
#include <cuefusion/segmentation/support_plane_removal.h>

#include <nlohmann/json_fwd.hpp>

#include <string>

namespace cuefusion
{
namespace pipeline
{
/** \brief The pipeline's Configs as settings JSON (io/settings_json.h): every field under
  * its own name, nested Configs nested, enumerations by name ("fused", "divergence",
  * "central"). This is what `cuefusion run --print-config` prints under "pipeline" and
  * what outputs.json records under "config". */
nlohmann::json
configJson (const FusionPipelineConfig& config);
nlohmann::json
configJson (const segmentation::GeometricSegmentationConfig& config);
nlohmann::json
configJson (const segmentation::InstanceGuidedRegionMergeConfig& config);
nlohmann::json
configJson (const segmentation::SupportPlaneRemovalConfig& config);

/** \brief Sets the fields \a json gives (a part of a file is fine; the rest keeps its
  * values); throws ParameterError naming the member's path (\a path "." field...) for a
  * name that is no field, a value of the wrong type, or a Config that then fails its
  * validate(). */
void
readConfig (const nlohmann::json& json, FusionPipelineConfig& config, const std::string& path = "pipeline");
void
readConfig (const nlohmann::json& json, segmentation::GeometricSegmentationConfig& config, const std::string& path = "geometry");
void
readConfig (const nlohmann::json& json, segmentation::InstanceGuidedRegionMergeConfig& config,
            const std::string& path = "instance_merge");
void
readConfig (const nlohmann::json& json, segmentation::SupportPlaneRemovalConfig& config, const std::string& path = "support_plane");
}  // namespace pipeline
}  // namespace cuefusion
