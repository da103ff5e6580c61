// SPDX-License-Identifier: BSD-3-Clause
// The field list of OnnxInstanceSegmenterConfig for settings files (io/settings_json.h):
// a field added to the Config is added here too.
#include <cuefusion/recognition/settings.h>

#include <cuefusion/io/settings_json.h>

namespace cuefusion
{
namespace recognition
{
template <class V>
void
fields (V& v, OnnxInstanceSegmenterConfig& c)
{
  v ("model_path", c.model_path);
  v ("classes_path", c.classes_path);
  v ("input_size", c.input_size);
  v ("dense_width", c.dense_width);
  v ("min_mask_pixels", c.min_mask_pixels);
  v ("score_threshold", c.score_threshold);
  v ("nms_threshold", c.nms_threshold);
  v ("mask_threshold", c.mask_threshold);
  v ("boundary_threshold", c.boundary_threshold);
  v ("stability_delta", c.stability_delta);
  v ("max_object_extent", c.max_object_extent);
  v ("max_detections", c.max_detections);
}

nlohmann::json
configJson (const OnnxInstanceSegmenterConfig& config)
{
  return io::settingsJson (config);
}

void
readConfig (const nlohmann::json& json, OnnxInstanceSegmenterConfig& config, const std::string& path)
{
  io::readSettings (json, config, path);
}
}  // namespace recognition
}  // namespace cuefusion
