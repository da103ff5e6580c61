#pragma once

#include <Eigen/Core>

#include <array>
#include <cstdint>
#include <string>
#include <vector>

namespace cuefusion
{
namespace io
{
/** \brief A triangle mesh as PLY files carry it: per-vertex position, optional colour and
  * segment label, and triangles. */
struct TriangleMesh
{
  std::vector<Eigen::Vector3f> vertices;
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
}  // namespace io
}  // namespace cuefusion
