// SPDX-License-Identifier: BSD-3-Clause
#pragma once

#include <Eigen/Core>
#include <pcl/PolygonMesh.h>

#include <array>
#include <cstdint>
#include <map>
#include <string>
#include <vector>

namespace cuefusion
{
namespace io
{
/** \brief A triangle mesh as PLY files carry it: per-vertex position, optional normal,
  * colour and segment label, and triangles. Compact (12 bytes a triangle; a
  * pcl::PolygonMesh spends about 56, a heap vector per face): what TSDFVolume extracts and
  * `run` writes. */
struct TriangleMesh
{
  std::vector<Eigen::Vector3f> vertices;
  std::vector<Eigen::Vector3f> normals;             ///< unit (zero where undefined), empty when none
  std::vector<std::array<std::uint8_t, 3>> colors;  ///< RGB, empty when the file has none
  std::vector<std::uint32_t> labels;                ///< empty when the file has no `label`
  std::vector<Eigen::Vector3i> triangles;
};

/** \brief Reads a binary little-endian PLY mesh: `cuefusion run`'s mesh.ply (x y z
  * [nx ny nz] red green blue label) or a ScanNet *_vh_clean_2.ply (x y z red green blue
  * alpha). Vertex properties of any scalar type are accepted and those not named above
  * skipped; faces must be lists of 3 indices (polygons with more are fanned). Written here
  * rather than with pcl::PLYReader because every size and index is checked, so a truncated
  * or corrupt file is a cuefusion::Error naming it, never a crash.
  */
TriangleMesh
readMeshPLY (const std::string& path);

/** \brief Writes \a mesh as binary little-endian PLY, atomically (temporary file, then
  * rename): x y z, then nx ny nz, red green blue and label where the mesh has them — what
  * readMeshPLY reads back and pcl_viewer or MeshLab open. Throws cuefusion::Error naming the
  * file when a per-vertex list's length is not the vertices' or a triangle names a vertex
  * the mesh does not have.
  */
void
writeMeshPLY (const std::string& path, const TriangleMesh& mesh);

/** \brief \a mesh as PCL holds meshes: a cloud with the fields of pcl::PointXYZRGBL (alpha
  * 255; colour and label 0 where the mesh has none) followed by those of pcl::Normal
  * (zero where the mesh has none), one polygon per triangle.
  */
pcl::PolygonMesh
toPolygonMesh (const TriangleMesh& mesh);

/** \brief One mesh per label (> 0) of a labelled mesh: the triangles whose three vertices
  * carry that label, with those vertices (and their normals, colours, labels) renumbered.
  * Triangles across labels, or of label 0, belong to none. Empty without labels.
  */
std::map<std::uint32_t, TriangleMesh>
splitByLabel (const TriangleMesh& mesh);
}  // namespace io
}  // namespace cuefusion
