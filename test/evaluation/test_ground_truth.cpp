// SPDX-License-Identifier: BSD-3-Clause
// Ground-truth readers: a ScanNet scene's annotation files (generated here in ScanNet's
// own format) and the synthetic sequence's labelled cloud.
#include "../test_utils.h"

#include <cuefusion/io/ground_truth.h>
#include <cuefusion/io/mesh_io.h>

#include <nlohmann/json.hpp>

#include <cstring>
#include <fstream>

using namespace cuefusion;

namespace
{
/** Writes a ScanNet-style binary PLY (x y z float, red green blue alpha uchar, faces as
  * uchar-counted int lists): a strip of \a n vertices along x, fanned into triangles. */
void
writeScanNetPly (const std::string& path, int n, bool truncate = false)
{
  std::ofstream out (path, std::ios::binary);
  out << "ply\nformat binary_little_endian 1.0\nelement vertex " << n
      << "\nproperty float x\nproperty float y\nproperty float z\nproperty uchar red\nproperty uchar green\n"
         "property uchar blue\nproperty uchar alpha\nelement face "
      << n - 2 << "\nproperty list uchar int vertex_indices\nend_header\n";
  for (int i = 0; i < n; ++i)
  {
    const float xyz[3] = {0.01f * static_cast<float> (i), static_cast<float> (i % 2) * 0.01f, 1.0f};
    const std::uint8_t rgba[4] = {static_cast<std::uint8_t> (i), 10, 20, 255};
    out.write (reinterpret_cast<const char*> (xyz), sizeof (xyz));
    out.write (reinterpret_cast<const char*> (rgba), sizeof (rgba));
  }
  const int faces = truncate ? (n - 2) / 2 : n - 2;
  for (int f = 0; f < faces; ++f)
  {
    const std::uint8_t three = 3;
    const std::int32_t idx[3] = {f, f + 1, f + 2};
    out.write (reinterpret_cast<const char*> (&three), 1);
    out.write (reinterpret_cast<const char*> (idx), sizeof (idx));
  }
}
}  // namespace

TEST (ScanNetGroundTruth, ReadsInstancesFromSegmentsAndAggregation)
{
  test::TempDir dir;
  const int n = 12;
  writeScanNetPly (dir / "scene0001_00_vh_clean_2.ply", n);
  // Over-segments: vertices 0–3 → segment 40, 4–7 → 41, 8–9 → 42, 10–11 → 43 (in no group).
  nlohmann::json segs = {{"sceneId", "scene0001_00"}, {"segIndices", {40, 40, 40, 40, 41, 41, 41, 41, 42, 42, 43, 43}}};
  test::writeFile (dir / "scene0001_00_vh_clean_2.0.010000.segs.json", segs.dump ());
  nlohmann::json aggregation = {
    {"sceneId", "scannet.scene0001_00"},
    {"appId", "Annotator.v1"},
    {"segGroups",
     {{{"id", 0}, {"objectId", 0}, {"segments", {40, 42}}, {"label", "chair"}},
      {{"id", 1}, {"objectId", 1}, {"segments", {41}}, {"label", "wall"}}}},
    {"segmentsFile", "scannet.scene0001_00_vh_clean_2.0.010000.segs.json"}};
  test::writeFile (dir / "scene0001_00.aggregation.json", aggregation.dump ());

  const auto files = io::findScanNetGroundTruth (dir.str ());
  ASSERT_TRUE (files.has_value ());
  const io::GroundTruthCloud gt = io::readScanNetGroundTruth (*files);
  ASSERT_EQ (gt.cloud->size (), static_cast<std::size_t> (n));
  const std::uint32_t expected[] = {1, 1, 1, 1, 2, 2, 2, 2, 1, 1, 0, 0};
  for (int i = 0; i < n; ++i)
  {
    EXPECT_EQ ((*gt.cloud)[static_cast<std::size_t> (i)].label, expected[i]) << i;
    EXPECT_FLOAT_EQ ((*gt.cloud)[static_cast<std::size_t> (i)].x, 0.01f * static_cast<float> (i));
  }
  EXPECT_EQ (gt.class_names.at (1), "chair");
  EXPECT_EQ (gt.class_names.at (2), "wall");
  EXPECT_EQ (gt.ignored, std::set<std::uint32_t> ({2}));  // wall is stuff by default
  // The mesh reader keeps colours and faces.
  const io::TriangleMesh mesh = io::readMeshPLY (files->mesh);
  EXPECT_EQ (mesh.triangles.size (), static_cast<std::size_t> (n - 2));
  ASSERT_EQ (mesh.colors.size (), static_cast<std::size_t> (n));
  EXPECT_EQ (mesh.colors[5][0], 5);
  EXPECT_TRUE (mesh.labels.empty ());
  // findGroundTruthCloud picks it up from the scene folder.
  EXPECT_TRUE (io::findGroundTruthCloud (dir.str ()).has_value ());

  // Bad input: a segment list of the wrong length, a truncated mesh, a broken aggregation.
  segs["segIndices"].erase (0);
  test::writeFile (dir / "scene0001_00_vh_clean_2.0.010000.segs.json", segs.dump ());
  test::expectError ([&] { io::readScanNetGroundTruth (*files); }, "segs.json", "11 segment indices");
  writeScanNetPly (dir / "truncated.ply", n, true);
  test::expectError ([&] { io::readMeshPLY (dir / "truncated.ply"); }, "truncated.ply", "truncated");
  test::writeFile (dir / "ascii.ply", "ply\nformat ascii 1.0\nelement vertex 0\nend_header\n");
  test::expectError ([&] { io::readMeshPLY (dir / "ascii.ply"); }, "ascii.ply", "binary_little_endian");
  test::expectError ([&] { io::readMeshPLY (dir / "missing.ply"); }, "missing.ply", "no such file");
  test::writeFile (dir / "scene0001_00.aggregation.json", "{\"segGroups\": [{\"id\": 0}]}");
  segs["segIndices"].insert (segs["segIndices"].begin (), 40);
  test::writeFile (dir / "scene0001_00_vh_clean_2.0.010000.segs.json", segs.dump ());
  test::expectError ([&] { io::readScanNetGroundTruth (*files); }, "aggregation.json", "segGroups");
}

TEST (ScanNetGroundTruth, MeshFaceIndexOutOfRangeIsAnError)
{
  test::TempDir dir;
  std::ofstream out (dir / "bad.ply", std::ios::binary);
  out << "ply\nformat binary_little_endian 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n"
         "element face 1\nproperty list uchar int vertex_indices\nend_header\n";
  const float xyz[9] = {0, 0, 0, 1, 0, 0, 0, 1, 0};
  out.write (reinterpret_cast<const char*> (xyz), sizeof (xyz));
  const std::uint8_t three = 3;
  const std::int32_t idx[3] = {0, 1, 7};
  out.write (reinterpret_cast<const char*> (&three), 1);
  out.write (reinterpret_cast<const char*> (idx), sizeof (idx));
  out.close ();
  test::expectError ([&] { io::readMeshPLY (dir / "bad.ply"); }, "bad.ply", "does not exist");
}
