// SPDX-License-Identifier: BSD-3-Clause
#include <cuefusion/io/file_io.h>
#include <cuefusion/io/map_io.h>

#include <cuefusion/common/exceptions.h>

#include <nlohmann/json.hpp>
#include <pcl/conversions.h>
#include <pcl/io/lzf.h>
#include <pcl/io/pcd_io.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <cstring>
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
  requireRegularFile (path);
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
  std::set<std::string> seen;
  for (int lines = 0; std::getline (in, line); ++lines)
  {
    if (lines > 64 || line.size () > 4096)
      fail ("no DATA line in its header");
    if (!line.empty () && line.back () == '\r')
      line.pop_back ();
    // PCL reads the header its own way (prefix matches, its own separators): only plain
    // text lines with known keys are accepted, so both readers see the same header.
    if (std::any_of (line.begin (), line.end (), [] (char c) { return c != '\t' && (c < 0x20 || c > 0x7e); }))
      fail ("header line " + std::to_string (lines + 1) + " is not text");
    std::istringstream words (line);
    std::string key;
    if (!(words >> key) || key[0] == '#')
      continue;
    static const char* const known[] = {"VERSION", "FIELDS", "SIZE", "TYPE", "COUNT", "WIDTH", "HEIGHT", "VIEWPOINT", "POINTS", "DATA"};
    if (std::find_if (std::begin (known), std::end (known), [&key] (const char* k) { return key == k; }) == std::end (known))
      fail ("unknown header line '" + key.substr (0, 20) + "'");
    if (!seen.insert (key).second)
      fail ("header line " + key + " appears twice");
    if ((key == "SIZE" || key == "TYPE" || key == "COUNT") && h.fields.empty ())
      fail (key + " before FIELDS");
    std::vector<std::string> values;
    for (std::string v; words >> v;)
      values.push_back (v);
    const std::size_t expected_values = key == "VIEWPOINT" ? 7 : (key == "WIDTH" || key == "HEIGHT" || key == "POINTS" || key == "DATA" || key == "VERSION") ? 1 : 0;
    if (expected_values > 0 && values.size () != expected_values)
      fail (key + " needs " + std::to_string (expected_values) + " value(s), has " + std::to_string (values.size ()));
    if (key == "VIEWPOINT")
      for (const std::string& v : values)
      {
        char* end = nullptr;
        const double x = std::strtod (v.c_str (), &end);
        if (end != v.c_str () + v.size () || !std::isfinite (x))
          fail ("VIEWPOINT value '" + v.substr (0, 20) + "' is not a number");
      }
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
    else if (key == "WIDTH")
      h.width = static_cast<std::uint64_t> (number (values[0], 1, 1LL << 31));
    else if (key == "HEIGHT")
      h.height = static_cast<std::uint64_t> (number (values[0], 1, 1LL << 31));
    else if (key == "POINTS")
    {
      h.points = static_cast<std::uint64_t> (number (values[0], 0, 1LL << 40));
      have_points = true;
    }
    else if (key == "DATA")
    {
      h.data = values[0];
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
    if (body > 100 * static_cast<std::uint64_t> (sizes[0]) + 64)  // LZF packs at most ~88:1
      fail ("its compressed data (" + std::to_string (sizes[0]) + " bytes) cannot hold " + std::to_string (body) + " bytes");
    if (sizes[1] != body)
      fail ("its compressed data unpacks to " + std::to_string (sizes[1]) + " bytes, the header promises " +
            std::to_string (body));
  }
  std::uint64_t elements = 0;  // numbers per point
  for (const int count : h.counts)
    elements += static_cast<std::uint64_t> (count);
  if (h.data == "ascii" && file_size - h.data_offset < h.points * elements)  // at least one character a number
    fail ("its text data is too short for " + std::to_string (h.points) + " points (truncated?)");
  return h;
}

/** An empty blob with the fields, sizes and data buffer \a h describes. The allocation
  * (points × point_step) is bounded by the file: checkPCDHeader made the body hold it
  * (binary), its compressed size hold it (at most ~100× for LZF) or one character a
  * number (ASCII). */
pcl::PCLPointCloud2
blobFromHeader (const PCDHeader& h)
{
  pcl::PCLPointCloud2 blob;
  blob.width = static_cast<std::uint32_t> (h.width);
  blob.height = static_cast<std::uint32_t> (h.height);
  blob.is_dense = false;
  std::uint32_t offset = 0;
  for (std::size_t i = 0; i < h.fields.size (); ++i)
  {
    pcl::PCLPointField field;
    field.name = h.fields[i];
    field.offset = offset;
    field.count = static_cast<std::uint32_t> (h.counts[i]);
    const int size = h.sizes[i];
    const char type = h.types[i];
    field.datatype = type == 'F' ? (size == 4 ? pcl::PCLPointField::FLOAT32 : pcl::PCLPointField::FLOAT64)
                     : type == 'I' ? (size == 1 ? pcl::PCLPointField::INT8 : size == 2 ? pcl::PCLPointField::INT16
                                      : size == 4 ? pcl::PCLPointField::INT32 : pcl::PCLPointField::INT64)
                                   : (size == 1 ? pcl::PCLPointField::UINT8 : size == 2 ? pcl::PCLPointField::UINT16
                                      : size == 4 ? pcl::PCLPointField::UINT32 : pcl::PCLPointField::UINT64);
    blob.fields.push_back (field);
    offset += static_cast<std::uint32_t> (size * h.counts[i]);
  }
  blob.point_step = offset;
  blob.row_step = blob.point_step * blob.width;
  blob.data.assign (static_cast<std::size_t> (h.points * h.point_step), 0);
  return blob;
}

/** The body of a binary PCD: the points as stored, or LZF-compressed with each field's
  * values together (PCL's binary_compressed layout), unpacked here. */
void
readBinaryBody (const std::string& path, const PCDHeader& h, pcl::PCLPointCloud2& blob)
{
  std::ifstream in (path, std::ios::binary);
  in.seekg (static_cast<std::streamoff> (h.data_offset));
  if (h.data == "binary")
  {
    in.read (reinterpret_cast<char*> (blob.data.data ()), static_cast<std::streamsize> (blob.data.size ()));
    if (!in)
      throw Error (path, "PCD binary data is truncated");
    return;
  }
  std::uint32_t sizes[2] = {0, 0};
  in.read (reinterpret_cast<char*> (sizes), sizeof sizes);
  std::vector<char> compressed (sizes[0]);
  in.read (compressed.data (), static_cast<std::streamsize> (compressed.size ()));
  if (!in)
    throw Error (path, "PCD compressed data is truncated");
  std::vector<std::uint8_t> fields_major (blob.data.size ());
  if (!fields_major.empty () &&
      pcl::lzfDecompress (compressed.data (), sizes[0], fields_major.data (), static_cast<unsigned int> (fields_major.size ())) !=
        fields_major.size ())
    throw Error (path, "PCD compressed data is corrupt (it does not unpack to " + std::to_string (fields_major.size ()) + " bytes)");
  std::size_t from = 0;
  for (const pcl::PCLPointField& field : blob.fields)
  {
    const std::size_t bytes = static_cast<std::size_t> (pcl::getFieldSize (field.datatype)) * field.count;
    for (std::size_t p = 0; p < h.points; ++p, from += bytes)
      std::memcpy (blob.data.data () + p * h.point_step + field.offset, fields_major.data () + from, bytes);
  }
}

/** The body of an ASCII PCD. Every number must parse completely and fit its field's type. */
void
readAsciiBody (const std::string& path, const PCDHeader& h, pcl::PCLPointCloud2& blob)
{
  std::ifstream in (path, std::ios::binary);
  in.seekg (static_cast<std::streamoff> (h.data_offset));
  std::string line;
  std::uint64_t point = 0;
  for (std::uint64_t line_number = 1; point < h.points && std::getline (in, line); ++line_number)
  {
    std::istringstream words (line);
    std::vector<std::string> tokens;
    for (std::string t; words >> t;)
      tokens.push_back (t);
    if (tokens.empty ())
      continue;
    const auto bad = [&] (const std::string& what) {
      return Error (path, "PCD data line " + std::to_string (line_number) + ": " + what);
    };
    std::size_t token = 0;
    std::uint8_t* out = blob.data.data () + point * h.point_step;
    for (std::size_t i = 0; i < h.fields.size (); ++i)
      for (int c = 0; c < h.counts[i]; ++c, ++token)
      {
        if (token >= tokens.size ())
          throw bad ("has " + std::to_string (tokens.size ()) + " numbers, a point has more");
        const std::string& text = tokens[token];
        char* end = nullptr;
        errno = 0;
        const int size = h.sizes[i];
        if (h.types[i] == 'F')
        {
          const double v = std::strtod (text.c_str (), &end);
          if (end != text.c_str () + text.size ())
            throw bad ("'" + text.substr (0, 20) + "' is not a number");
          if (size == 4)
          {
            const float f = static_cast<float> (v);  // out-of-range values become ±inf
            std::memcpy (out, &f, 4);
          }
          else
            std::memcpy (out, &v, 8);
        }
        else if (h.types[i] == 'I')
        {
          const long long v = std::strtoll (text.c_str (), &end, 10);
          const long long limit = size == 8 ? std::numeric_limits<long long>::max () : (1LL << (8 * size - 1)) - 1;
          if (end != text.c_str () + text.size () || errno == ERANGE || v > limit || v < -limit - 1)
            throw bad ("'" + text.substr (0, 20) + "' is not an integer of " + std::to_string (size) + " bytes");
          const std::int64_t value = v;  // little-endian: the low bytes are the value
          std::memcpy (out, &value, static_cast<std::size_t> (size));
        }
        else
        {
          const unsigned long long v = std::strtoull (text.c_str (), &end, 10);
          const unsigned long long limit = size == 8 ? std::numeric_limits<unsigned long long>::max () : (1ULL << (8 * size)) - 1;
          if (end != text.c_str () + text.size () || errno == ERANGE || text[0] == '-' || v > limit)
            throw bad ("'" + text.substr (0, 20) + "' is not an unsigned integer of " + std::to_string (size) + " bytes");
          const std::uint64_t value = v;
          std::memcpy (out, &value, static_cast<std::size_t> (size));
        }
        out += size;
      }
    if (token != tokens.size ())
      throw bad ("has " + std::to_string (tokens.size ()) + " numbers, a point has " + std::to_string (token));
    ++point;
  }
  if (point < h.points)
    throw Error (path, "PCD text data holds " + std::to_string (point) + " points, the header promises " +
                         std::to_string (h.points) + " (truncated?)");
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
  // Read here, not with pcl::io::loadPCDFile: PCL 1.13's reader dereferences null or
  // overruns its buffers on headers and bodies it does not expect (fuzz_pcd found lines of
  // whitespace before the header and malformed ASCII bodies), and PCL has no way to
  // bound what it allocates. The format is simple: ASCII, raw binary, or LZF-compressed.
  pcl::PCLPointCloud2 blob = blobFromHeader (header);
  if (header.data == "ascii")
    readAsciiBody (path, header, blob);
  else
    readBinaryBody (path, header, blob);
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

}  // namespace io
}  // namespace cuefusion
