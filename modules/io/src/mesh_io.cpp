// SPDX-License-Identifier: BSD-3-Clause
#include <cuefusion/common/exceptions.h>
#include <cuefusion/io/file_io.h>
#include <cuefusion/io/map_io.h>
#include <cuefusion/io/mesh_io.h>

#include <pcl/common/io.h>
#include <pcl/conversions.h>
#include <pcl/point_types.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <fstream>
#include <sstream>

namespace cuefusion
{
namespace io
{
namespace
{
enum class ScalarType
{
  Int8,
  UInt8,
  Int16,
  UInt16,
  Int32,
  UInt32,
  Float32,
  Float64
};

bool
parseScalarType (const std::string& name, ScalarType& type)
{
  static const std::pair<const char*, ScalarType> names[] = {
    {"char", ScalarType::Int8},    {"int8", ScalarType::Int8},     {"uchar", ScalarType::UInt8},  {"uint8", ScalarType::UInt8},
    {"short", ScalarType::Int16},  {"int16", ScalarType::Int16},   {"ushort", ScalarType::UInt16}, {"uint16", ScalarType::UInt16},
    {"int", ScalarType::Int32},    {"int32", ScalarType::Int32},   {"uint", ScalarType::UInt32},  {"uint32", ScalarType::UInt32},
    {"float", ScalarType::Float32}, {"float32", ScalarType::Float32}, {"double", ScalarType::Float64}, {"float64", ScalarType::Float64}};
  for (const auto& [n, t] : names)
    if (name == n)
    {
      type = t;
      return true;
    }
  return false;
}

std::size_t
sizeOf (ScalarType type)
{
  switch (type)
  {
    case ScalarType::Int8:
    case ScalarType::UInt8: return 1;
    case ScalarType::Int16:
    case ScalarType::UInt16: return 2;
    case ScalarType::Int32:
    case ScalarType::UInt32:
    case ScalarType::Float32: return 4;
    case ScalarType::Float64: return 8;
  }
  return 0;
}

double
readScalar (const char* p, ScalarType type)
{
  switch (type)
  {
    case ScalarType::Int8: return static_cast<double> (*reinterpret_cast<const std::int8_t*> (p));
    case ScalarType::UInt8: return static_cast<double> (*reinterpret_cast<const std::uint8_t*> (p));
    case ScalarType::Int16: { std::int16_t v; std::memcpy (&v, p, 2); return v; }
    case ScalarType::UInt16: { std::uint16_t v; std::memcpy (&v, p, 2); return v; }
    case ScalarType::Int32: { std::int32_t v; std::memcpy (&v, p, 4); return v; }
    case ScalarType::UInt32: { std::uint32_t v; std::memcpy (&v, p, 4); return v; }
    case ScalarType::Float32: { float v; std::memcpy (&v, p, 4); return v; }
    case ScalarType::Float64: { double v; std::memcpy (&v, p, 8); return v; }
  }
  return 0.0;
}

struct Property
{
  std::string name;
  ScalarType type = ScalarType::Float32;
  bool list = false;
  ScalarType count_type = ScalarType::UInt8;
};

struct Element
{
  std::string name;
  std::size_t count = 0;
  std::vector<Property> properties;
};
/** A colour channel of any stored type as a byte: rounded and clamped (NaN → 0). */
std::uint8_t
colorByte (double value)
{
  return value >= 0.0 ? static_cast<std::uint8_t> (std::min (255.0, std::round (value))) : 0;
}

/** An open PLY file and how many bytes are left in it. Every count is checked against
  * the bytes left before anything is allocated: a small file declaring 10^9 vertices is an
  * error, not a 17 GB allocation. */
struct PlyInput
{
  const std::string& path;
  std::ifstream in;
  std::uint64_t file_size = 0;

  std::uint64_t
  left ()
  {
    return file_size - std::min<std::uint64_t> (file_size, static_cast<std::uint64_t> (in.tellg ()));
  }
};

/** Reads the header up to end_header: the elements with their properties. */
std::vector<Element>
readPlyHeader (PlyInput& ply)
{
  const std::string& path = ply.path;
  std::string line;
  if (!std::getline (ply.in, line) || line.rfind ("ply", 0) != 0)
    throw Error (path, "not a PLY file");
  std::vector<Element> elements;
  bool binary_le = false;
  for (;;)
  {
    if (!std::getline (ply.in, line))
      throw Error (path, "PLY header has no end_header");
    if (!line.empty () && line.back () == '\r')
      line.pop_back ();
    std::istringstream words (line);
    std::string key;
    words >> key;
    if (key == "end_header")
      break;
    if (key == "format")
    {
      std::string format;
      words >> format;
      binary_le = format == "binary_little_endian";
      if (!binary_le)
        throw Error (path, "PLY format '" + format + "' is not supported (binary_little_endian only)");
    }
    else if (key == "element")
    {
      Element e;
      long long count = -1;
      words >> e.name >> count;
      if (!words || count < 0)
        throw Error (path, "malformed PLY element line: " + line);
      e.count = static_cast<std::size_t> (count);
      elements.push_back (e);
    }
    else if (key == "property")
    {
      if (elements.empty ())
        throw Error (path, "PLY property before any element");
      Property p;
      std::string type;
      words >> type;
      if (type == "list")
      {
        std::string count_type, item_type;
        words >> count_type >> item_type >> p.name;
        p.list = true;
        if (!parseScalarType (count_type, p.count_type) || !parseScalarType (item_type, p.type))
          throw Error (path, "unknown PLY list type in: " + line);
      }
      else
      {
        words >> p.name;
        if (!parseScalarType (type, p.type))
          throw Error (path, "unknown PLY property type in: " + line);
      }
      elements.back ().properties.push_back (p);
    }
  }
  if (!binary_le)
    throw Error (path, "PLY header has no format line");
  return elements;
}

/** The vertex element: positions, normals (nx, ny, nz), colours (red, green, blue) and
  * labels when present. */
void
readPlyVertices (PlyInput& ply, const Element& e, TriangleMesh& mesh)
{
  const std::string& path = ply.path;
  std::size_t stride = 0;
  int ix = -1, iy = -1, iz = -1, inx = -1, iny = -1, inz = -1, ir = -1, ig = -1, ib = -1, il = -1;
  std::vector<std::size_t> offsets;
  for (std::size_t k = 0; k < e.properties.size (); ++k)
  {
    const Property& p = e.properties[k];
    if (p.list)
      throw Error (path, "list properties on vertices are not supported");
    offsets.push_back (stride);
    stride += sizeOf (p.type);
    const int index = static_cast<int> (k);
    if (p.name == "x") ix = index;
    else if (p.name == "y") iy = index;
    else if (p.name == "z") iz = index;
    else if (p.name == "nx") inx = index;
    else if (p.name == "ny") iny = index;
    else if (p.name == "nz") inz = index;
    else if (p.name == "red") ir = index;
    else if (p.name == "green") ig = index;
    else if (p.name == "blue") ib = index;
    else if (p.name == "label") il = index;
  }
  if (ix < 0 || iy < 0 || iz < 0)
    throw Error (path, "PLY vertices have no x, y, z");
  const bool color = ir >= 0 && ig >= 0 && ib >= 0;
  const bool normal = inx >= 0 && iny >= 0 && inz >= 0;
  if (e.count > ply.left () / stride)
    throw Error (path, "PLY declares " + std::to_string (e.count) + " vertices but the file holds " +
                         std::to_string (ply.left () / stride) + " (truncated?)");
  std::vector<char> data (e.count * stride);
  if (!ply.in.read (data.data (), static_cast<std::streamsize> (data.size ())))
    throw Error (path, "PLY file ends inside its vertex data (truncated?)");
  mesh.vertices.resize (e.count);
  if (normal)
    mesh.normals.resize (e.count);
  if (color)
    mesh.colors.resize (e.count);
  if (il >= 0)
    mesh.labels.resize (e.count);
  const auto value = [&] (std::size_t v, int k) {
    return readScalar (data.data () + v * stride + offsets[static_cast<std::size_t> (k)], e.properties[static_cast<std::size_t> (k)].type);
  };
  for (std::size_t v = 0; v < e.count; ++v)
  {
    mesh.vertices[v] = Eigen::Vector3f (static_cast<float> (value (v, ix)), static_cast<float> (value (v, iy)),
                                        static_cast<float> (value (v, iz)));
    if (normal)
      mesh.normals[v] = Eigen::Vector3f (static_cast<float> (value (v, inx)), static_cast<float> (value (v, iny)),
                                         static_cast<float> (value (v, inz)));
    if (color)
      mesh.colors[v] = {colorByte (value (v, ir)), colorByte (value (v, ig)), colorByte (value (v, ib))};
    if (il >= 0)
    {
      const double label = value (v, il);
      if (!(label >= 0.0 && label <= 4294967295.0) || label != std::floor (label))
        throw Error (path, "vertex " + std::to_string (v) + " has label " + std::to_string (label) +
                             ", not an integer in [0, 2^32)");
      mesh.labels[v] = static_cast<std::uint32_t> (label);
    }
  }
}

/** The face element: every polygon of vertex_indices (or vertex_index) as a fan of
  * triangles; every index must name a vertex read before. */
void
readPlyFaces (PlyInput& ply, const Element& e, TriangleMesh& mesh)
{
  const std::string& path = ply.path;
  std::size_t smallest_face = 0;
  for (const Property& p : e.properties)
  {
    smallest_face += sizeOf (p.list ? p.count_type : p.type);
    if (p.list && (p.type == ScalarType::Float32 || p.type == ScalarType::Float64 ||
                   p.count_type == ScalarType::Float32 || p.count_type == ScalarType::Float64))
      throw Error (path, "PLY face list '" + p.name + "' must hold integers");
  }
  if (smallest_face == 0 || e.count > ply.left () / smallest_face)
    throw Error (path, "PLY declares " + std::to_string (e.count) + " faces, more than the file can hold (truncated?)");
  for (std::size_t f = 0; f < e.count; ++f)
    for (const Property& p : e.properties)
    {
      char buffer[8];
      if (!ply.in.read (buffer, static_cast<std::streamsize> (sizeOf (p.list ? p.count_type : p.type))))
        throw Error (path, "PLY file ends inside its face data (truncated?)");
      if (!p.list)
        continue;
      const double n = readScalar (buffer, p.count_type);
      if (!(n >= 0 && n <= 1024))
        throw Error (path, "PLY face " + std::to_string (f) + " has an absurd vertex count");
      std::vector<int> indices (static_cast<std::size_t> (n));
      for (int& index : indices)
      {
        if (!ply.in.read (buffer, static_cast<std::streamsize> (sizeOf (p.type))))
          throw Error (path, "PLY file ends inside its face data (truncated?)");
        const double v = readScalar (buffer, p.type);
        if (!(v >= 0 && v < static_cast<double> (mesh.vertices.size ())))
          throw Error (path, "PLY face " + std::to_string (f) + " indexes a vertex that does not exist");
        index = static_cast<int> (v);
      }
      if (p.name != "vertex_indices" && p.name != "vertex_index")
        continue;
      for (std::size_t k = 2; k < indices.size (); ++k)
        mesh.triangles.emplace_back (indices[0], indices[k - 1], indices[k]);
    }
}

/** Skips an element of another name (only fixed-size ones can be skipped unparsed). */
void
skipPlyElement (PlyInput& ply, const Element& e)
{
  std::size_t stride = 0;
  for (const Property& p : e.properties)
  {
    if (p.list)
      throw Error (ply.path, "cannot skip PLY element '" + e.name + "' with list properties");
    stride += sizeOf (p.type);
  }
  if (stride > 0 && e.count > ply.left () / stride)
    throw Error (ply.path, "PLY element '" + e.name + "' is longer than the file (truncated?)");
  ply.in.seekg (static_cast<std::streamoff> (stride * e.count), std::ios::cur);
}
}  // namespace

TriangleMesh
readMeshPLY (const std::string& path)
{
  const FileContext context (path);
  requireRegularFile (path);
  PlyInput ply{path, std::ifstream (path, std::ios::binary)};
  if (!ply.in)
    throw Error (path, "cannot open mesh");
  ply.in.seekg (0, std::ios::end);
  ply.file_size = static_cast<std::uint64_t> (ply.in.tellg ());
  ply.in.seekg (0);
  const std::vector<Element> elements = readPlyHeader (ply);
  TriangleMesh mesh;
  bool have_vertices = false;
  for (const Element& e : elements)
  {
    if (e.name == "vertex")
    {
      if (have_vertices)
        throw Error (path, "PLY file has two vertex elements");
      have_vertices = true;
      readPlyVertices (ply, e, mesh);
    }
    else if (e.name == "face")
    {
      if (!have_vertices)
        throw Error (path, "PLY faces come before vertices");
      readPlyFaces (ply, e, mesh);
    }
    else
      skipPlyElement (ply, e);
  }
  if (!have_vertices)
    throw Error (path, "PLY file has no vertex element");
  return mesh;
}
namespace
{
template <typename T>
void
put (std::ostream& out, const T& value)
{
  out.write (reinterpret_cast<const char*> (&value), sizeof value);
}

/** A vertex label as the header's `int`. */
void
putLabel (std::ostream& out, std::uint32_t label, const std::string& path)
{
  if (label > 0x7fffffffu)
    throw Error (path, "label " + std::to_string (label) + " does not fit the PLY label property (int)");
  put (out, static_cast<std::int32_t> (label));
}

/** What a PLY mesh written by cuefusion holds. */
struct PlyLayout
{
  std::size_t vertices = 0, faces = 0;
  bool normals = false, colors = false, labels = false;
};

/** Writes the header of \a layout, then lets \a body write the vertex and face records;
  * atomically (temporary file, then rename). */
template <typename Body>
void
writePly (const std::string& path, const PlyLayout& layout, Body body)
{
  std::ostringstream header;
  header << "ply\nformat binary_little_endian 1.0\ncomment written by cuefusion\n"
         << "element vertex " << layout.vertices << "\nproperty float x\nproperty float y\nproperty float z\n";
  if (layout.normals)
    header << "property float nx\nproperty float ny\nproperty float nz\n";
  if (layout.colors)
    header << "property uchar red\nproperty uchar green\nproperty uchar blue\n";
  // int, not uint: Open3D 0.16's PLY reader skips unsigned properties ("unsupported
  // datatype uint"); labels stay far below 2^31 (putLabel refuses one that is not).
  if (layout.labels)
    header << "property int label\n";
  header << "element face " << layout.faces << "\nproperty list uchar int vertex_indices\nend_header\n";
  writeFileAtomic (path, [&] (const std::string& tmp) {
    std::ofstream out (tmp, std::ios::binary);
    out << header.str ();
    body (out);
    out.close ();
    return static_cast<bool> (out);
  });
}
}  // namespace

void
writeMeshPLY (const std::string& path, const TriangleMesh& mesh)
{
  const FileContext context (path);
  const std::size_t n = mesh.vertices.size ();
  const auto check = [&] (std::size_t count, const char* what) {
    if (count != 0 && count != n)
      throw Error (path, "mesh has " + std::to_string (count) + " " + what + " for " + std::to_string (n) + " vertices");
  };
  check (mesh.normals.size (), "normals");
  check (mesh.colors.size (), "colours");
  check (mesh.labels.size (), "labels");
  for (const Eigen::Vector3i& t : mesh.triangles)
    if ((t.array () < 0).any () || (t.array () >= static_cast<int> (std::min<std::size_t> (n, 0x7fffffff))).any ())
      throw Error (path, "mesh face indexes a vertex it does not have");
  const PlyLayout layout{n, mesh.triangles.size (), !mesh.normals.empty (), !mesh.colors.empty (), !mesh.labels.empty ()};
  writePly (path, layout, [&] (std::ostream& out) {
    for (std::size_t i = 0; i < n; ++i)
    {
      for (int k = 0; k < 3; ++k)
        put (out, mesh.vertices[i][k]);
      if (layout.normals)
        for (int k = 0; k < 3; ++k)
          put (out, mesh.normals[i][k]);
      if (layout.colors)
        for (const std::uint8_t c : mesh.colors[i])
          put (out, c);
      if (layout.labels)
        putLabel (out, mesh.labels[i], path);
    }
    for (const Eigen::Vector3i& t : mesh.triangles)
    {
      put (out, std::uint8_t (3));
      for (int k = 0; k < 3; ++k)
        put (out, static_cast<std::int32_t> (t[k]));
    }
  });
}

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
  PlyLayout layout;
  layout.vertices = points.size ();
  layout.faces = mesh.polygons.size ();
  layout.normals = hasField (mesh.cloud, "normal_x");
  layout.colors = hasField (mesh.cloud, "rgb") || hasField (mesh.cloud, "rgba");
  layout.labels = hasField (mesh.cloud, "label");
  if (layout.normals)
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
  writePly (path, layout, [&] (std::ostream& out) {
    for (std::size_t i = 0; i < points.size (); ++i)
    {
      const auto& p = points[i];
      put (out, p.x);
      put (out, p.y);
      put (out, p.z);
      if (layout.normals)
      {
        put (out, normals[i].normal_x);
        put (out, normals[i].normal_y);
        put (out, normals[i].normal_z);
      }
      if (layout.colors)
      {
        put (out, p.r);
        put (out, p.g);
        put (out, p.b);
      }
      if (layout.labels)
        putLabel (out, p.label, path);
    }
    for (const auto& face : mesh.polygons)
    {
      put (out, static_cast<std::uint8_t> (face.vertices.size ()));
      for (const auto v : face.vertices)
        put (out, static_cast<std::int32_t> (v));
    }
  });
}

pcl::PolygonMesh
toPolygonMesh (const TriangleMesh& mesh)
{
  const std::size_t n = mesh.vertices.size ();
  pcl::PolygonMesh out;
  pcl::PCLPointCloud2 a, b;
  {
    pcl::PointCloud<pcl::PointXYZRGBL> points;
    points.resize (n);
    for (std::size_t i = 0; i < n; ++i)
    {
      pcl::PointXYZRGBL& p = points[i];
      p.getVector3fMap () = mesh.vertices[i];
      if (!mesh.colors.empty ())
      {
        p.r = mesh.colors[i][0];
        p.g = mesh.colors[i][1];
        p.b = mesh.colors[i][2];
      }
      p.a = 255;
      p.label = mesh.labels.empty () ? 0 : mesh.labels[i];
    }
    pcl::toPCLPointCloud2 (points, a);
  }
  {
    pcl::PointCloud<pcl::Normal> normals;
    normals.resize (n);
    for (std::size_t i = 0; i < n; ++i)
    {
      normals[i].getNormalVector3fMap () = mesh.normals.empty () ? Eigen::Vector3f::Zero () : mesh.normals[i];
      normals[i].curvature = 0.f;
    }
    pcl::toPCLPointCloud2 (normals, b);
  }
  pcl::concatenateFields (a, b, out.cloud);
  out.polygons.resize (mesh.triangles.size ());
  for (std::size_t t = 0; t < mesh.triangles.size (); ++t)
    out.polygons[t].vertices = {static_cast<pcl::index_t> (mesh.triangles[t][0]), static_cast<pcl::index_t> (mesh.triangles[t][1]),
                                static_cast<pcl::index_t> (mesh.triangles[t][2])};
  return out;
}
std::map<std::uint32_t, TriangleMesh>
splitByLabel (const TriangleMesh& mesh)
{
  std::map<std::uint32_t, TriangleMesh> out;
  if (mesh.labels.size () != mesh.vertices.size ())
    return out;
  // Per label, the new index of each old vertex (filled as triangles are met).
  std::map<std::uint32_t, std::map<int, int>> renumbered;
  for (const Eigen::Vector3i& t : mesh.triangles)
  {
    const std::uint32_t label = mesh.labels[static_cast<std::size_t> (t[0])];
    if (label == 0 || mesh.labels[static_cast<std::size_t> (t[1])] != label || mesh.labels[static_cast<std::size_t> (t[2])] != label)
      continue;
    TriangleMesh& part = out[label];
    std::map<int, int>& index = renumbered[label];
    Eigen::Vector3i local;
    for (int k = 0; k < 3; ++k)
    {
      const auto [it, added] = index.emplace (t[k], static_cast<int> (part.vertices.size ()));
      if (added)
      {
        const auto v = static_cast<std::size_t> (t[k]);
        part.vertices.push_back (mesh.vertices[v]);
        if (!mesh.normals.empty ())
          part.normals.push_back (mesh.normals[v]);
        if (!mesh.colors.empty ())
          part.colors.push_back (mesh.colors[v]);
        part.labels.push_back (label);
      }
      local[k] = it->second;
    }
    part.triangles.push_back (local);
  }
  return out;
}
}  // namespace io
}  // namespace cuefusion
