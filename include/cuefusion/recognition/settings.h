// SPDX-License-Identifier: BSD-3-Clause
#pragma once

#include <cuefusion/recognition/onnx_instance_segmenter.h>

#include <nlohmann/json_fwd.hpp>

#include <string>

namespace cuefusion
{
namespace recognition
{
/** \brief OnnxInstanceSegmenterConfig as settings JSON (io/settings_json.h): the
  * "network" part of `--print-config` and of outputs.json's "config". */
nlohmann::json
configJson (const OnnxInstanceSegmenterConfig& config);

/** \brief Sets the fields \a json gives; ParameterError naming \a path "." field for a
  * name that is no field or a value of the wrong type. The ranges are checked when the
  * segmenter is built (validate() needs a model path, which a file may leave to the
  * command line). */
void
readConfig (const nlohmann::json& json, OnnxInstanceSegmenterConfig& config, const std::string& path = "network");
}  // namespace recognition
}  // namespace cuefusion
