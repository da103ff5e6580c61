#include <cuefusion/io/file_io.h>
#include <cuefusion/io/map_io.h>

#include <cuefusion/common/exceptions.h>

#include <pcl/conversions.h>
#include <nlohmann/json.hpp>
#include <pcl/io/pcd_io.h>

#include <algorithm>
#include <cstdint>
#include <fstream>
#include <limits>
#include <set>
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

namespace
{
/** What the header of a PCD file promises, checked field by field. */
struct PCDHeader
{
  std::vector<std::string> fields;
  std::vector<int> sizes, counts;
  std::vector<char> types;
  std::uint64_t width = 0, height = 0, points = 0, point_step = 0;
  std::string data;
  std::uint64_t data_offset = 0;  ///< first byte after the DATA line
};

// PCL 1.13 trusts its headers: COUNT -1, compressed sizes of 0 or a body shorter than
// POINTS × point_step crash it or overrun its buffers. Everything is checked here first,
// and no allocation is larger than the file can fill.
PCDHeader
checkPCDHeader (const std::string& path)
{
  std::ifstream in (path, std::ios::binary);
  if (!in)
    throw Error (path, "cannot open PCD file");
  in.seekg (0, std::ios::end);
  const std::uint64_t file_size = static_cast<std::uint64_t> (in.tellg ());
  in.seekg (0);
  PCDHeader h;
  auto fail = [&path] (const std::string& what) { throw Error (path, "not a valid PCD file: " + what); };
  std::string line;
  bool have_points = false;
  for (int lines = 0; std::getline (in, line); ++lines)
  {
    if (lines > 64 || line.size () > 4096)
      fail ("no DATA line in its header");
    if (!line.empty () && line.back () == '\r')
      line.pop_back ();
    std::istringstream words (line);
    std::string key;
    if (!(words >> key) || key[0] == '#')
      continue;
    std::vector<std::string> values;
    for (std::string v; words >> v;)
      values.push_back (v);
    auto number = [&] (const std::string& text, long long lo, long long hi) {
      std::size_t used = 0;
      long long v = 0;
      try
      {
        v = std::stoll (text, &used);
      }
      catch (const std::exception&)
      {
        used = 0;
      }
      if (used != text.size () || v < lo || v > hi)
        fail (key + " value '" + text.substr (0, 40) + "' is not an integer in [" + std::to_string (lo) + ", " +
              std::to_string (hi) + "]");
      return v;
    };
    if (key == "FIELDS")
      h.fields = values;
    else if (key == "SIZE")
      for (const std::string& v : values)
      {
        const long long size = number (v, 1, 8);
        if (size != 1 && size != 2 && size != 4 && size != 8)
          fail ("SIZE " + v + " (must be 1, 2, 4 or 8)");
        h.sizes.push_back (static_cast<int> (size));
      }
    else if (key == "TYPE")
      for (const std::string& v : values)
      {
        if (v != "F" && v != "I" && v != "U")
          fail ("TYPE '" + v.substr (0, 10) + "' (must be F, I or U)");
        h.types.push_back (v[0]);
      }
    else if (key == "COUNT")
      for (const std::string& v : values)
        h.counts.push_back (static_cast<int> (number (v, 1, 1 << 20)));
    else if (key == "WIDTH" && !values.empty ())
      h.width = static_cast<std::uint64_t> (number (values[0], 1, 1LL << 31));
    else if (key == "HEIGHT" && !values.empty ())
      h.height = static_cast<std::uint64_t> (number (values[0], 1, 1LL << 31));
    else if (key == "POINTS" && !values.empty ())
    {
      h.points = static_cast<std::uint64_t> (number (values[0], 0, 1LL << 40));
      have_points = true;
    }
    else if (key == "DATA")
    {
      h.data = values.empty () ? "" : values[0];
      h.data_offset = static_cast<std::uint64_t> (in.tellg ());
      break;
    }
  }
  if (h.data.empty () || !in)
    fail ("no DATA line in its header");
  if (h.data != "ascii" && h.data != "binary" && h.data != "binary_compressed")
    fail ("DATA '" + h.data.substr (0, 20) + "' (must be ascii, binary or binary_compressed)");
  if (h.fields.empty ())
    fail ("no FIELDS");
  if (h.counts.empty ())
    h.counts.assign (h.fields.size (), 1);
  if (h.sizes.size () != h.fields.size () || h.types.size () != h.fields.size () || h.counts.size () != h.fields.size ())
    fail (std::to_string (h.fields.size ()) + " FIELDS but " + std::to_string (h.sizes.size ()) + " SIZE, " +
          std::to_string (h.types.size ()) + " TYPE and " + std::to_string (h.counts.size ()) + " COUNT values");
  for (std::size_t i = 0; i < h.fields.size (); ++i)
  {
    if (h.types[i] == 'F' && h.sizes[i] != 4 && h.sizes[i] != 8)
      fail ("field '" + h.fields[i] + "' is a float of " + std::to_string (h.sizes[i]) + " bytes");
    h.point_step += static_cast<std::uint64_t> (h.sizes[i]) * static_cast<std::uint64_t> (h.counts[i]);
  }
  if (h.width == 0 || h.height == 0)
    fail ("no WIDTH or HEIGHT");
  if (have_points && h.points != h.width * h.height)
    fail ("POINTS " + std::to_string (h.points) + " is not WIDTH × HEIGHT = " + std::to_string (h.width * h.height));
  h.points = h.width * h.height;
  const std::uint64_t body = h.points * h.point_step;
  if (h.data == "binary" && file_size < h.data_offset + body)
    fail ("its binary data holds " + std::to_string (file_size - h.data_offset) + " bytes, the header promises " +
          std::to_string (body) + " (truncated?)");
  if (h.data == "binary_compressed")
  {
    std::uint32_t sizes[2] = {0, 0};
    in.read (reinterpret_cast<char*> (sizes), sizeof sizes);
    if (!in || sizes[0] == 0 || h.data_offset + 8 + sizes[0] > file_size)
      fail ("its compressed data is missing or shorter than its size field says (truncated?)");
    if (sizes[1] != body)
      fail ("its compressed data unpacks to " + std::to_string (sizes[1]) + " bytes, the header promises " +
            std::to_string (body));
  }
  if (h.data == "ascii" && file_size - h.data_offset < h.points * h.fields.size ())
    fail ("its text data is too short for " + std::to_string (h.points) + " points (truncated?)");
  return h;
}
}  // namespace

pcl::PCLPointCloud2
readPCD (const std::string& path, const std::vector<std::string>& required_fields)
{
  const FileContext context (path);
  const PCDHeader header = checkPCDHeader (path);
  for (const std::string& field : required_fields)
  {
    const auto it = std::find (header.fields.begin (), header.fields.end (), field);
    if (it == header.fields.end ())
      throw Error (path, "PCD has no '" + field + "' field");
    const std::size_t i = static_cast<std::size_t> (it - header.fields.begin ());
    const bool coordinate = field == "x" || field == "y" || field == "z";
    if (coordinate && (header.types[i] != 'F' || header.sizes[i] != 4 || header.counts[i] != 1))
      throw Error (path, "PCD field '" + field + "' must be one 4-byte float (TYPE F, SIZE 4, COUNT 1)");
    if (field == "label" && (header.types[i] == 'F' || header.sizes[i] != 4 || header.counts[i] != 1))
      throw Error (path, "PCD field 'label' must be one 4-byte integer (TYPE U or I, SIZE 4, COUNT 1)");
  }
  pcl::PCLPointCloud2 blob;
  int status = -1;
  try
  {
    status = pcl::io::loadPCDFile (path, blob);
  }
  catch (const std::exception& e)
  {
    throw Error (path, std::string ("cannot read PCD file (") + e.what () + ")");
  }
  if (status < 0)
    throw Error (path, "cannot read PCD file (truncated or corrupt)");
  if (blob.data.size () != static_cast<std::size_t> (blob.width) * blob.height * blob.point_step)
    throw Error (path, "PCD data does not match its header (" + std::to_string (blob.data.size ()) + " bytes read)");
  return blob;
}

void
saveMapPCD (const std::string& path, const pcl::PointCloud<pcl::PointXYZRGBL>& cloud)
{
  const FileContext context (path);
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
  const FileContext context (path);
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
std::vector<SegmentEntry>
readSegmentsJson (const std::string& path)
{
  const FileContext context (path);
  const nlohmann::json doc = readJsonFile (path);
  if (!doc.is_object () || !doc.contains ("segments") || !doc.at ("segments").is_array ())
    throw Error (path, "malformed segments.json: no list \"segments\"");
  std::vector<SegmentEntry> entries;
  std::set<std::uint32_t> seen;
  for (const nlohmann::json& s : doc.at ("segments"))
  {
    const auto bad = [&] (const std::string& what) { return Error (path, "malformed segments.json: " + what); };
    if (!s.is_object () || !s.contains ("id") || !s.at ("id").is_number_unsigned () || s.at ("id").get<std::uint64_t> () == 0 ||
        s.at ("id").get<std::uint64_t> () > std::numeric_limits<std::uint32_t>::max ())
      throw bad ("every segment needs an integer \"id\" in [1, 2^32), got " +
                 (s.is_object () && s.contains ("id") ? s.at ("id").dump () : std::string ("none")));
    SegmentEntry entry;
    entry.id = s.at ("id").get<std::uint32_t> ();
    if (!seen.insert (entry.id).second)
      throw bad ("segment id " + std::to_string (entry.id) + " appears twice");
    if (s.contains ("class") && !s.at ("class").is_null ())
    {
      if (!s.at ("class").is_string ())
        throw bad ("segment " + std::to_string (entry.id) + ": \"class\" must be a string or null");
      entry.class_name = s.at ("class").get<std::string> ();
    }
    if (s.contains ("score") && !s.at ("score").is_null ())
    {
      entry.score = s.at ("score").is_number () ? s.at ("score").get<double> () : -1.0;
      if (!(entry.score >= 0.0 && entry.score <= 1.0))
        throw bad ("segment " + std::to_string (entry.id) + ": \"score\" must be a number in [0, 1] or null, got " +
                   s.at ("score").dump ());
    }
    entries.push_back (entry);
  }
  return entries;
}
}  // namespace io
}  // namespace cuefusion
