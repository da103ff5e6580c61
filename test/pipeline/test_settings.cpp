// SPDX-License-Identifier: BSD-3-Clause
// Settings files (io/settings_json.h, pipeline/settings.h): every field of the pipeline's
// Configs is written and read under its own name, and reading is strict.
#include <cuefusion/common/exceptions.h>
#include <cuefusion/io/settings_json.h>
#include <cuefusion/pipeline/settings.h>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <cmath>
#include <functional>
#include <string>
#include <vector>

using namespace cuefusion;

namespace
{
/** Every leaf of \a j (arrays are leaves) with its path of member names. */
void
leaves (const nlohmann::json& j, std::vector<std::string>& path, std::vector<std::vector<std::string>>& out)
{
  if (!j.is_object ())
  {
    out.push_back (path);
    return;
  }
  for (auto it = j.begin (); it != j.end (); ++it)
  {
    path.push_back (it.key ());
    leaves (*it, path, out);
    path.pop_back ();
  }
}

nlohmann::json&
at (nlohmann::json& j, const std::vector<std::string>& path)
{
  nlohmann::json* p = &j;
  for (const std::string& key : path)
    p = &(*p)[key];
  return *p;
}

std::string
joined (const std::vector<std::string>& path)
{
  std::string s;
  for (const std::string& key : path)
    s += (s.empty () ? "" : ".") + key;
  return s;
}

/** Values other than \a v of the same kind, nearest first (some fields take only odd or
  * bounded values: the first their validate() accepts is used). */
std::vector<nlohmann::json>
otherValues (const nlohmann::json& v, const std::vector<std::string>& path)
{
  if (v.is_boolean ())
    return {!v.get<bool> ()};
  if (v.is_string ())
  {
    const std::string& s = v.get_ref<const std::string&> ();
    if (path.back () == "mode")
      return {s == "geometry" ? "masks" : "geometry"};
    if (path.back () == "convexity_test")
      return {s == "divergence" ? "tangent" : "divergence"};
    if (path.back () == "normal_method")
      return {s == "central" ? "integral" : "central"};
    return {s + "x"};
  }
  if (v.is_number_integer ())
  {
    const long long i = v.get<long long> ();
    return {i + 2, i + 1, i - 1, i * 2};
  }
  if (v.is_number ())
  {
    const double d = v.get<double> ();
    return {d * 0.75, d * 1.1, d + 0.25, d == 0 ? 0.5 : -d};
  }
  if (v.is_array ())
  {
    nlohmann::json a = v;
    if (a.empty ())
      return {nlohmann::json::array ({1})};
    a[0] = a[0].get<int> () + 1;
    return {a};
  }
  if (v.is_null ())  // the volume's bounds
    return {{{"min", {-1.0, -2.0, -3.0}}, {"max", {1.0, 2.0, 3.0}}}};
  return {};
}

/** For every field of \a Config's JSON: a changed value read into a default Config and
  * written again changes that field and no other (a field read into the wrong member, or
  * not read, or not written, fails). */
template <class Config>
void
everyFieldRoundTrips (const std::string& name)
{
  const nlohmann::json defaults = pipeline::configJson (Config ());
  std::vector<std::string> path;
  std::vector<std::vector<std::string>> all;
  leaves (defaults, path, all);
  EXPECT_GT (all.size (), 5u) << name;
  for (const std::vector<std::string>& field : all)
  {
    bool round_trip = false;
    std::string last_error;
    for (const nlohmann::json& value : otherValues (at (const_cast<nlohmann::json&> (defaults), field), field))
    {
      nlohmann::json changed = defaults;
      at (changed, field) = value;
      Config config;
      try
      {
        pipeline::readConfig (changed, config, name);
      }
      catch (const ParameterError& e)
      {
        last_error = e.what ();
        continue;  // outside the field's range: try the next value
      }
      nlohmann::json written = pipeline::configJson (config);
      if (value.is_number_float ())  // a float field holds the nearest float
      {
        EXPECT_NEAR (at (written, field).get<double> (), value.get<double> (), 1e-6 * std::abs (value.get<double> ()))
          << name << "." << joined (field);
        at (written, field) = value;
      }
      EXPECT_EQ (written, changed) << name << "." << joined (field);  // that field changed, and no other
      round_trip = true;
      break;
    }
    EXPECT_TRUE (round_trip) << name << "." << joined (field) << ": no changed value was accepted (" << last_error << ")";
  }
}
}  // namespace

TEST (Settings, EveryFieldOfThePipelinesConfigsRoundTrips)
{
  everyFieldRoundTrips<pipeline::FusionPipelineConfig> ("pipeline");
  everyFieldRoundTrips<segmentation::GeometricSegmentationConfig> ("geometry");
  everyFieldRoundTrips<segmentation::InstanceGuidedRegionMergeConfig> ("instance_merge");
  everyFieldRoundTrips<segmentation::SupportPlaneRemovalConfig> ("support_plane");
  // The defaults are the Configs' own: a file without members changes nothing.
  pipeline::FusionPipelineConfig c;
  pipeline::readConfig (nlohmann::json::object (), c);
  EXPECT_EQ (pipeline::configJson (c), pipeline::configJson (pipeline::FusionPipelineConfig ()));
}

TEST (Settings, FloatsAreWrittenAsTheirShortestDecimal)
{
  segmentation::InstanceGuidedRegionMergeConfig c;
  c.min_overlap = 0.7f;
  c.color_split_distance = 0.1f;
  const nlohmann::json j = pipeline::configJson (c);
  EXPECT_EQ (j.at ("min_overlap").dump (), "0.7");
  EXPECT_EQ (j.at ("color_split_distance").dump (), "0.1");
  segmentation::InstanceGuidedRegionMergeConfig back;
  pipeline::readConfig (j, back);
  EXPECT_EQ (back.min_overlap, 0.7f);  // the same float, bit for bit
  EXPECT_EQ (back.color_split_distance, 0.1f);
}

TEST (Settings, ReadingIsStrictAndABadFileChangesNothing)
{
  struct Case
  {
    const char* json;
    const char* names;  ///< the member path the error must name
  };
  const Case cases[] = {
    {R"({"reconstruction": {"volume": {"voxel_sise": 0.02}}})", "pipeline.reconstruction.volume.voxel_sise"},
    {R"({"reconstruction": {"volume": {"voxel_size": "fine"}}})", "pipeline.reconstruction.volume.voxel_size"},
    {R"({"reconstruction": {"hole_refresh_period": -1}})", "pipeline.reconstruction.hole_refresh_period"},
    {R"({"reconstruction": {"hole_refresh_period": 2.5}})", "pipeline.reconstruction.hole_refresh_period"},
    {R"({"reconstruction": {"tracking": {"min_inliers": 1e30}}})", "pipeline.reconstruction.tracking.min_inliers"},
    {R"({"reconstruction": {"tracking": {"icp": {"iterations": [10, "five"]}}}})", "pipeline.reconstruction.tracking.icp.iterations[1]"},
    {R"({"reconstruction": {"keyframes": {"size": [80]}}})", "pipeline.reconstruction.keyframes.size"},
    {R"({"reconstruction": {"volume": {"bounds": {"min": [0, 0]}}}})", "pipeline.reconstruction.volume.bounds"},
    {R"({"reconstruction": {"motion_model": 1}})", "pipeline.reconstruction.motion_model"},
    {R"({"mode": "everything"})", "pipeline.mode"},
    {R"({"geometry": {"concavity": 0.9}})", "pipeline.geometry.concavity"},
    {R"({"instance_merge": {"min_overlap": 1e300}})", "pipeline.instance_merge.min_overlap"},
    {R"({"reconstruction": {"volume": {"voxel_size": 0}}})", "TSDFVolumeConfig::voxel_size"},  // validate()
    {R"([1, 2])", "pipeline"},
  };
  for (const Case& c : cases)
  {
    pipeline::FusionPipelineConfig config;
    config.reconstruction.volume.voxel_size = 0.02;  // not the default: kept through a failed read
    const nlohmann::json before = pipeline::configJson (config);
    try
    {
      pipeline::readConfig (nlohmann::json::parse (c.json), config);
      ADD_FAILURE () << c.json << " was accepted";
    }
    catch (const ParameterError& e)
    {
      EXPECT_NE (std::string (e.what ()).find (c.names), std::string::npos) << e.what ();
      EXPECT_EQ (std::string (e.what ()).find ('\n'), std::string::npos) << e.what ();
    }
    EXPECT_EQ (pipeline::configJson (config), before) << c.json;
  }
  // A part of a file sets those fields only.
  pipeline::FusionPipelineConfig config;
  pipeline::readConfig (nlohmann::json::parse (R"({"reconstruction": {"tracking": {"icp": {"iterations": [3, 2]}}}, "mode": "masks"})"),
                        config);
  EXPECT_EQ (config.reconstruction.tracking.icp.iterations, (std::vector<int>{3, 2}));
  EXPECT_EQ (config.mode, pipeline::SegmentationMode::Masks);
  config.reconstruction.tracking.icp.iterations = pipeline::FusionPipelineConfig ().reconstruction.tracking.icp.iterations;
  config.mode = pipeline::FusionPipelineConfig ().mode;
  EXPECT_EQ (pipeline::configJson (config), pipeline::configJson (pipeline::FusionPipelineConfig ()));
}
