// SPDX-License-Identifier: BSD-3-Clause
#include <cuefusion/common/exceptions.h>
#include <cuefusion/io/file_io.h>
#include <cuefusion/io/ground_truth.h>
#include <cuefusion/io/map_io.h>
#include <cuefusion/io/mesh_io.h>

#include <boost/filesystem.hpp>
#include <nlohmann/json.hpp>
#include <pcl/conversions.h>

namespace fs = boost::filesystem;

namespace cuefusion
{
namespace io
{
namespace
{
bool
endsWith (const std::string& s, const std::string& suffix)
{
  return s.size () >= suffix.size () && s.compare (s.size () - suffix.size (), suffix.size (), suffix) == 0;
}
}  // namespace

std::set<std::string>
defaultStuffClasses ()
{
  return {"wall", "floor", "ceiling"};
}

GroundTruthCloud
readScanNetGroundTruth (const ScanNetGroundTruthFiles& files, const std::set<std::string>& stuff_classes)
{
  const TriangleMesh mesh = readMeshPLY (files.mesh);
  std::vector<long long> seg_indices;
  try
  {
    const nlohmann::json segs = readJsonFile (files.segments);
    seg_indices = segs.at ("segIndices").get<std::vector<long long>> ();
  }
  catch (const nlohmann::json::exception& e)
  {
    throw Error (files.segments, std::string ("not a ScanNet segs.json (no integer list \"segIndices\"): ") + e.what ());
  }
  if (seg_indices.size () != mesh.vertices.size ())
    throw Error (files.segments, "has " + std::to_string (seg_indices.size ()) + " segment indices but " + files.mesh + " has " +
                                     std::to_string (mesh.vertices.size ()) + " vertices");

  GroundTruthCloud gt;
  gt.source = files.mesh;
  std::map<long long, std::uint32_t> segment_instance;
  try
  {
    const nlohmann::json aggregation = readJsonFile (files.aggregation);
    for (const nlohmann::json& group : aggregation.at ("segGroups"))
    {
      const long long object = group.contains ("objectId") ? group.at ("objectId").get<long long> () : group.at ("id").get<long long> ();
      if (object < 0 || object > 1000000)
        throw Error (files.aggregation, "objectId " + std::to_string (object) + " out of range");
      const auto id = static_cast<std::uint32_t> (object + 1);
      const std::string label = group.at ("label").get<std::string> ();
      gt.class_names[id] = label;
      if (stuff_classes.count (label))
        gt.ignored.insert (id);
      for (const long long s : group.at ("segments").get<std::vector<long long>> ())
        segment_instance[s] = id;
    }
  }
  catch (const nlohmann::json::exception& e)
  {
    throw Error (files.aggregation, std::string ("not a ScanNet aggregation file (segGroups with objectId, label, segments): ") + e.what ());
  }
  gt.cloud = pcl::make_shared<pcl::PointCloud<pcl::PointXYZL>> ();
  gt.cloud->resize (mesh.vertices.size ());
  for (std::size_t i = 0; i < mesh.vertices.size (); ++i)
  {
    pcl::PointXYZL& p = (*gt.cloud)[i];
    p.getVector3fMap () = mesh.vertices[i];
    const auto it = segment_instance.find (seg_indices[i]);
    p.label = it == segment_instance.end () ? 0u : it->second;
  }
  return gt;
}

std::optional<ScanNetGroundTruthFiles>
findScanNetGroundTruth (const std::string& folder)
{
  if (!fs::is_directory (folder))
    return std::nullopt;
  ScanNetGroundTruthFiles files;
  for (const fs::directory_entry& entry : fs::directory_iterator (folder))
  {
    const std::string name = entry.path ().filename ().string ();
    if (endsWith (name, "_vh_clean_2.ply"))
      files.mesh = entry.path ().string ();
    else if (endsWith (name, "_vh_clean_2.0.010000.segs.json"))
      files.segments = entry.path ().string ();
    else if (endsWith (name, ".aggregation.json") && (files.aggregation.empty () || !endsWith (name, "_vh_clean.aggregation.json")))
      files.aggregation = entry.path ().string ();  // prefer <scene>.aggregation.json
  }
  if (files.mesh.empty () || files.segments.empty () || files.aggregation.empty ())
    return std::nullopt;
  return files;
}

std::set<std::uint32_t>
syntheticStuffInstances (const std::string& folder)
{
  std::set<std::uint32_t> stuff;
  const fs::path scene = fs::path (folder) / "scene.json";
  if (!fs::exists (scene))
    return stuff;
  try
  {
    const nlohmann::json j = readJsonFile (scene.string ());
    for (const nlohmann::json& instance : j.at ("instances"))
      if (!instance.value ("detectable", true))
        stuff.insert (instance.at ("id").get<std::uint32_t> ());
  }
  catch (const nlohmann::json::exception& e)
  {
    throw Error (scene.string (), std::string ("malformed scene.json: ") + e.what ());
  }
  return stuff;
}

GroundTruthCloud
readSyntheticGroundTruth (const std::string& folder)
{
  const FileContext context (folder);
  const fs::path cloud_path = fs::path (folder) / "gt_cloud.pcd";
  const pcl::PCLPointCloud2 blob = readPCD (cloud_path.string (), {"x", "y", "z", "label"});
  GroundTruthCloud gt;
  gt.source = cloud_path.string ();
  gt.cloud = pcl::make_shared<pcl::PointCloud<pcl::PointXYZL>> ();
  pcl::fromPCLPointCloud2 (blob, *gt.cloud);
  const fs::path scene = fs::path (folder) / "scene.json";
  if (fs::exists (scene))
  {
    try
    {
      const nlohmann::json j = readJsonFile (scene.string ());
      for (const nlohmann::json& instance : j.at ("instances"))
      {
        const auto id = instance.at ("id").get<std::uint32_t> ();
        gt.class_names[id] = instance.value ("class_name", std::string ());
        if (!instance.value ("detectable", true))  // as syntheticStuffInstances, without reading the file again
          gt.ignored.insert (id);
      }
    }
    catch (const nlohmann::json::exception& e)
    {
      throw Error (scene.string (), std::string ("malformed scene.json: ") + e.what ());
    }
  }
  return gt;
}

std::optional<GroundTruthCloud>
findGroundTruthCloud (const std::string& folder)
{
  if (fs::exists (fs::path (folder) / "gt_cloud.pcd"))
    return readSyntheticGroundTruth (folder);
  if (const auto files = findScanNetGroundTruth (folder))
    return readScanNetGroundTruth (*files);
  return std::nullopt;
}
}  // namespace io
}  // namespace cuefusion
