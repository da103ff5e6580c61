#include <cuefusion/io/file_io.h>
#include <cuefusion/io/map_io.h>

#include <cuefusion/common/exceptions.h>

#include <pcl/conversions.h>
#include <pcl/io/pcd_io.h>

#include <fstream>
#include <sstream>

namespace cuefusion
{
namespace io
{
bool
hasField (const pcl::PCLPointCloud2& cloud, const std::string& name)
{
  for (const auto& f : cloud.fields)
    if (f.name == name)
      return true;
  return false;
}

pcl::PCLPointCloud2
readPCD (const std::string& path, const std::vector<std::string>& required_fields)
{
  pcl::PCLPointCloud2 blob;
  {
    pcl::PCDReader reader;
    Eigen::Vector4f origin;
    Eigen::Quaternionf orientation;
    int version = 0, data_type = 0;
    unsigned int data_offset = 0;
    if (reader.readHeader (path, blob, origin, orientation, version, data_type, data_offset) < 0 || blob.fields.empty () ||
        static_cast<std::size_t> (blob.width) * blob.height == 0)
      throw Error (path, "not a PCD file with points (no FIELDS, WIDTH or HEIGHT in its header)");
  }
  if (pcl::io::loadPCDFile (path, blob) < 0)
    throw Error (path, "cannot read PCD file (truncated or corrupt)");
  for (const std::string& field : required_fields)
    if (!hasField (blob, field))
      throw Error (path, "PCD has no '" + field + "' field");
  return blob;
}

void
saveMapPCD (const std::string& path, const pcl::PointCloud<pcl::PointXYZRGBL>& cloud)
{
  writeFileAtomic (path, [&cloud] (const std::string& tmp) {
    // PCL refuses to write an empty cloud in binary; an empty map is still a valid answer.
    return (cloud.empty () ? pcl::io::savePCDFileASCII (tmp, cloud) : pcl::io::savePCDFileBinaryCompressed (tmp, cloud)) == 0;
  });
}

namespace
{

template <typename T>
void
put (std::ostream& out, const T& value)
{
  out.write (reinterpret_cast<const char*> (&value), sizeof value);
}
}  // namespace

// PCL's own PLY writer drops the label field, which is the point of a labelled mesh.
void
saveMeshPLY (const std::string& path, const pcl::PolygonMesh& mesh)
{
  if (!hasField (mesh.cloud, "x") || !hasField (mesh.cloud, "y") || !hasField (mesh.cloud, "z"))
    throw Error (path, "mesh has no vertex positions");
  pcl::PointCloud<pcl::PointXYZRGBL> points;
  pcl::PointCloud<pcl::Normal> normals;
  pcl::fromPCLPointCloud2 (mesh.cloud, points);
  const bool with_normals = hasField (mesh.cloud, "normal_x");
  const bool with_color = hasField (mesh.cloud, "rgb") || hasField (mesh.cloud, "rgba");
  const bool with_label = hasField (mesh.cloud, "label");
  if (with_normals)
    pcl::fromPCLPointCloud2 (mesh.cloud, normals);
  const auto vertex_count = static_cast<pcl::index_t> (points.size ());
  for (const auto& face : mesh.polygons)
  {
    if (face.vertices.size () > 255)
      throw Error (path, "mesh has a face of more than 255 vertices");
    for (const auto v : face.vertices)
      if (v < 0 || v >= vertex_count)
        throw Error (path, "mesh face indexes a vertex it does not have");
  }

  std::ostringstream header;
  header << "ply\nformat binary_little_endian 1.0\ncomment written by cuefusion\n"
         << "element vertex " << points.size () << "\nproperty float x\nproperty float y\nproperty float z\n";
  if (with_normals)
    header << "property float nx\nproperty float ny\nproperty float nz\n";
  if (with_color)
    header << "property uchar red\nproperty uchar green\nproperty uchar blue\n";
  if (with_label)
    header << "property uint label\n";
  header << "element face " << mesh.polygons.size () << "\nproperty list uchar int vertex_indices\nend_header\n";

  writeFileAtomic (path, [&] (const std::string& tmp) {
    std::ofstream out (tmp, std::ios::binary);
    out << header.str ();
    for (std::size_t i = 0; i < points.size (); ++i)
    {
      const auto& p = points[i];
      put (out, p.x);
      put (out, p.y);
      put (out, p.z);
      if (with_normals)
      {
        put (out, normals[i].normal_x);
        put (out, normals[i].normal_y);
        put (out, normals[i].normal_z);
      }
      if (with_color)
      {
        put (out, p.r);
        put (out, p.g);
        put (out, p.b);
      }
      if (with_label)
        put (out, static_cast<std::uint32_t> (p.label));
    }
    for (const auto& face : mesh.polygons)
    {
      put (out, static_cast<std::uint8_t> (face.vertices.size ()));
      for (const auto v : face.vertices)
        put (out, static_cast<std::int32_t> (v));
    }
    out.close ();
    return static_cast<bool> (out);
  });
}
}  // namespace io
}  // namespace cuefusion
