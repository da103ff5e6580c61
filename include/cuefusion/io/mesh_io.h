// SPDX-License-Identifier: BSD-3-Clause
#pragma once

#include <cuefusion/common/triangle_mesh.h>

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
/** \brief The mesh type the PLY readers and writers take (common/triangle_mesh.h; the
  * name io::TriangleMesh is kept for code written before it moved). */
using TriangleMesh = cuefusion::TriangleMesh;

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
