// SPDX-License-Identifier: BSD-3-Clause
// Files that lie about themselves are errors naming the file, never crashes or huge
// allocations: PCD headers are checked before PCL reads a body (PCL 1.13 crashes or
// overruns its buffers on COUNT -1, compressed sizes of 0 or a body shorter than the
// header says); PLY counts are checked against the file's size, and face lists against
// the vertices.
#include "test_utils.h"

#include <cuefusion/common/exceptions.h>
#include <cuefusion/common/instance.h>
#include <cuefusion/io/camera_io.h>
#include <cuefusion/io/file_io.h>
#include <cuefusion/io/map_io.h>
#include <cuefusion/io/mesh_io.h>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <pcl/io/pcd_io.h>

#include <cmath>
#include <cstdint>
#include <initializer_list>
#include <string>

using namespace cuefusion;

namespace
{
std::string
header (const std::string& fields, const std::string& size, const std::string& type, const std::string& count,
        const std::string& width, const std::string& height, const std::string& points, const std::string& data)
{
  return "# .PCD v0.7\nVERSION 0.7\nFIELDS " + fields + "\nSIZE " + size + "\nTYPE " + type + "\nCOUNT " + count +
         "\nWIDTH " + width + "\nHEIGHT " + height + "\nVIEWPOINT 0 0 0 1 0 0 0\nPOINTS " + points + "\nDATA " + data + "\n";
}

std::string
floats (int n)
{
  return std::string (static_cast<std::size_t> (n) * 4, '\0');
}

struct Case
{
  const char* name;
  std::string bytes;
  const char* message;
};
}  // namespace

TEST (BadPCD, EveryHeaderLieIsAnErrorNamingTheFile)
{
  test::TempDir dir;
  const std::uint32_t zero_sizes[2] = {0, 0};
  const std::uint32_t wrong_sizes[2] = {4, 999};
  const Case cases[] = {
    {"count_minus_one", header ("x y z", "4 4 4", "F F F", "1 -1 1", "2", "1", "2", "binary") + floats (6), "COUNT"},
    {"compressed_zero", header ("x y z", "4 4 4", "F F F", "1 1 1", "2", "2", "4", "binary_compressed") +
                          std::string (reinterpret_cast<const char*> (zero_sizes), 8),
     "compressed data is missing"},
    {"compressed_wrong_size", header ("x y z", "4 4 4", "F F F", "1 1 1", "2", "2", "4", "binary_compressed") +
                                std::string (reinterpret_cast<const char*> (wrong_sizes), 8) + "abcd",
     "unpacks to 999 bytes"},
    {"short_body", header ("x y z", "4 4 4", "F F F", "1 1 1", "4", "1", "4", "binary") + floats (3), "truncated"},
    {"type_q", header ("x y z", "4 4 4", "F Q F", "1 1 1", "1", "1", "1", "binary") + floats (3), "TYPE 'Q'"},
    {"size_zero", header ("x y z", "4 0 4", "F F F", "1 1 1", "1", "1", "1", "binary") + floats (3), "SIZE"},
    {"size_three", header ("x y z", "4 3 4", "F F F", "1 1 1", "1", "1", "1", "binary") + floats (3), "SIZE 3"},
    {"float_of_two_bytes", header ("x y z", "4 2 4", "F F F", "1 1 1", "1", "1", "1", "binary") + floats (3),
     "float of 2 bytes"},
    {"integer_x", header ("x y z", "4 4 4", "I F F", "1 1 1", "1", "1", "1", "binary") + floats (3), "4-byte float"},
    {"points_mismatch", header ("x y z", "4 4 4", "F F F", "1 1 1", "2", "2", "3", "binary") + floats (12), "POINTS 3"},
    {"fields_mismatch", header ("x y z", "4 4", "F F F", "1 1 1", "1", "1", "1", "binary") + floats (3), "2 SIZE"},
    {"no_data_line", "# .PCD v0.7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nWIDTH 1\nHEIGHT 1\n", "no DATA"},
    {"data_kind", header ("x y z", "4 4 4", "F F F", "1 1 1", "1", "1", "1", "zip") + floats (3), "DATA 'zip'"},
    {"huge_width", header ("x y z", "4 4 4", "F F F", "1 1 1", "99999999999", "1", "99999999999", "binary"), "WIDTH"},
    {"no_z", header ("x y", "4 4", "F F", "1 1", "1", "1", "1", "binary") + floats (2), "no 'z' field"},
    {"ascii_short", header ("x y z", "4 4 4", "F F F", "1 1 1", "100", "1", "100", "ascii") + "1 2 3\n", "too short"},
  };
  for (const Case& c : cases)
  {
    const std::string path = dir / (std::string (c.name) + ".pcd");
    test::writeFile (path, c.bytes);
    test::expectError ([&] { io::readPCD (path); }, path, c.message);
  }
}

TEST (BadPCD, ValidFilesStillRead)
{
  test::TempDir dir;
  pcl::PointCloud<pcl::PointXYZRGBL> cloud (3, 2);
  for (std::size_t i = 0; i < cloud.size (); ++i)
  {
    cloud[i].x = static_cast<float> (i);
    cloud[i].y = -0.25f * static_cast<float> (i);
    cloud[i].z = 1.f / static_cast<float> (i + 1);
    cloud[i].rgba = 0x01020304u * static_cast<std::uint32_t> (i + 1);
    cloud[i].label = static_cast<std::uint32_t> (i + 1);
  }
  for (const std::string kind : {"ascii", "binary", "compressed"})
  {
    const std::string path = dir / (kind + ".pcd");
    if (kind == "ascii")
      pcl::io::savePCDFileASCII (path, cloud);
    else if (kind == "binary")
      pcl::io::savePCDFileBinary (path, cloud);
    else
      pcl::io::savePCDFileBinaryCompressed (path, cloud);
    const pcl::PCLPointCloud2 blob = io::readPCD (path, {"x", "y", "z", "label"});
    EXPECT_EQ (blob.width, 3u) << kind;
    EXPECT_EQ (blob.height, 2u) << kind;
    pcl::PointCloud<pcl::PointXYZRGBL> back;
    pcl::fromPCLPointCloud2 (blob, back);
    EXPECT_EQ (back[5].label, 6u) << kind;
    EXPECT_FLOAT_EQ (back[4].x, 4.f) << kind;
    // cuefusion reads PCDs itself (PCL's reader crashes on malformed files): the same
    // fields and bytes as PCL's reader on every valid file.
    pcl::PCLPointCloud2 by_pcl;
    ASSERT_EQ (pcl::io::loadPCDFile (path, by_pcl), 0);
    ASSERT_EQ (blob.fields.size (), by_pcl.fields.size ()) << kind;
    for (std::size_t f = 0; f < blob.fields.size (); ++f)
    {
      EXPECT_EQ (blob.fields[f].name, by_pcl.fields[f].name) << kind;
      EXPECT_EQ (blob.fields[f].offset, by_pcl.fields[f].offset) << kind;
      EXPECT_EQ (blob.fields[f].datatype, by_pcl.fields[f].datatype) << kind;
      EXPECT_EQ (blob.fields[f].count, by_pcl.fields[f].count) << kind;
    }
    EXPECT_EQ (blob.point_step, by_pcl.point_step) << kind;
    EXPECT_TRUE (blob.data == by_pcl.data) << kind;
  }
}

TEST (BadPCD, SegmentFrameGivesOneLineAndExitOne)
{
  test::TempDir dir;
  const std::string bad = dir / "bad.pcd";
  test::writeFile (bad, header ("x y z", "4 4 4", "F F F", "1 -1 1", "2", "2", "4", "binary") + floats (12));
  const auto r = test::runCuefusion ("segment-frame " + bad + " --out " + (dir / "o.pcd"), dir);
  EXPECT_EQ (r.code, 1);
  EXPECT_NE (r.err.find (bad), std::string::npos) << r.err;
  EXPECT_EQ (std::count (r.err.begin (), r.err.end (), '\n'), 1) << r.err;
}

namespace
{
std::string
plyHeader (const std::string& elements)
{
  return "ply\nformat binary_little_endian 1.0\n" + elements + "end_header\n";
}

template <typename T>
std::string
bytesOf (std::initializer_list<T> values)
{
  std::string out;
  for (const T v : values)
    out.append (reinterpret_cast<const char*> (&v), sizeof v);
  return out;
}
}  // namespace

TEST (BadPLY, CountsAndIndicesAreCheckedAgainstTheFile)
{
  test::TempDir dir;
  const std::string vertex = "element vertex 3\nproperty float x\nproperty float y\nproperty float z\n";
  const std::string three = bytesOf<float> ({0, 0, 0, 1, 0, 0, 0, 1, 0});
  const std::string face_int = "element face 1\nproperty list uchar int vertex_indices\n";
  const Case cases[] = {
    {"billion_vertices", plyHeader ("element vertex 1000000000\nproperty float x\nproperty float y\nproperty float z\n") + three,
     "declares 1000000000 vertices"},
    {"two_vertex_blocks", plyHeader (vertex + vertex) + three + three, "two vertex elements"},
    {"float_face_list", plyHeader (vertex + "element face 1\nproperty list uchar float vertex_indices\n") + three +
                          std::string (1, '\3') + bytesOf<float> ({0, 1, std::nanf ("")}),
     "must hold integers"},
    {"negative_index", plyHeader (vertex + face_int) + three + std::string (1, '\3') + bytesOf<int> ({0, 1, -2147483647 - 1}),
     "indexes a vertex that does not exist"},
    {"index_past_end", plyHeader (vertex + face_int) + three + std::string (1, '\3') + bytesOf<int> ({0, 1, 3}),
     "indexes a vertex that does not exist"},
    {"million_faces", plyHeader (vertex + "element face 1000000\nproperty list uchar int vertex_indices\n") + three +
                        std::string (1, '\3') + bytesOf<int> ({0, 1, 2}),
     "more than the file can hold"},
    {"long_extra_element", plyHeader (vertex + "element extra 99999999\nproperty double w\n") + three, "longer than the file"},
  };
  for (const Case& c : cases)
  {
    const std::string path = dir / (std::string (c.name) + ".ply");
    test::writeFile (path, c.bytes);
    test::expectError ([&] { io::readMeshPLY (path); }, path, c.message);
  }
  // The same file with a valid face reads.
  const std::string good = dir / "good.ply";
  test::writeFile (good, plyHeader (vertex + face_int) + three + std::string (1, '\3') + bytesOf<int> ({0, 1, 2}));
  const io::TriangleMesh mesh = io::readMeshPLY (good);
  EXPECT_EQ (mesh.vertices.size (), 3u);
  ASSERT_EQ (mesh.triangles.size (), 1u);
}

TEST (BadJSON, DeepNestingIsRefusedWhileParsing)
{
  test::TempDir dir;
  const std::string deep = dir / "segments.json";
  test::writeFile (deep, std::string (1000000, '[') + std::string (1000000, ']'));
  test::expectError ([&] { io::readJsonFile (deep); }, deep, "nested deeper than 64 levels");
  const std::string fine = dir / "fine.json";
  test::writeFile (fine, std::string (60, '[') + std::string (60, ']'));
  EXPECT_NO_THROW (io::readJsonFile (fine));
}

TEST (BadMasks, AnIdImageOfThousandsOfIdsIsRefusedCheaply)
{
  cv::Mat ids (240, 320, CV_16U);
  for (int i = 0; i < ids.rows * ids.cols; ++i)
    ids.at<std::uint16_t> (i / ids.cols, i % ids.cols) = static_cast<std::uint16_t> (1 + i % 65535);
  test::expectError ([&] { instancesFromIdImage (ids); }, "instance id image", "65535 distinct instance ids");
  // A thousand small instances are still read, each mask exactly its pixels.
  cv::Mat some = cv::Mat::zeros (240, 320, CV_16U);
  for (int k = 0; k < 1000; ++k)
    some.at<std::uint16_t> (k / 40 * 4, k % 40 * 4) = static_cast<std::uint16_t> (k + 1);
  const auto instances = instancesFromIdImage (some);
  ASSERT_EQ (instances.size (), 1000u);
  EXPECT_EQ (cv::countNonZero (instances[999].mask), 1);
  EXPECT_EQ (instances[999].mask.at<std::uint8_t> (24 * 4, 39 * 4), 1);
}

TEST (BadIntrinsics, AbsurdValuesAreRefusedWithTheFileNamed)
{
  test::TempDir dir;
  const std::pair<const char*, const char*> cases[] = {
    {"tiny_focal.txt", "1e-300 525 319.5 239.5"},
    {"huge_centre.txt", "525 525 1e30 239.5"},
    {"huge_width.txt", "525 525 319.5 239.5 4294967616 240"},
    {"wide.json", R"({"intrinsic_matrix": [525, 0, 0, 0, 525, 0, 319.5, 239.5, 1], "width": 4294967616, "height": 240})"},
    {"fraction.json", R"({"intrinsic_matrix": [525, 0, 0, 0, 525, 0, 319.5, 239.5, 1], "width": 320.5, "height": 240})"},
  };
  for (const auto& [name, text] : cases)
  {
    const std::string path = dir / name;
    test::writeFile (path, text);
    EXPECT_THROW (io::readIntrinsics (path), Error) << name;
    test::expectError ([&] { io::readIntrinsics (path); }, path, "");
  }
  test::writeFile (dir / "good.json",
                   R"({"intrinsic_matrix": [525, 0, 0, 0, 525, 0, 319.5, 239.5, 1], "width": 640, "height": 480})");
  const PinholeCamera camera = io::readIntrinsics (dir / "good.json");
  EXPECT_EQ (camera.width, 640);
  EXPECT_DOUBLE_EQ (camera.cx, 319.5);
}
