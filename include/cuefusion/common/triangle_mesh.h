// SPDX-License-Identifier: BSD-3-Clause
#pragma once

#include <Eigen/Core>

#include <array>
#include <cstdint>
#include <vector>

namespace cuefusion
{
/** \brief A triangle mesh as PLY files carry it: per-vertex position, optional normal,
  * colour and segment label, and triangles. Compact (12 bytes a triangle; a
  * pcl::PolygonMesh spends about 56, a heap vector per face): what TSDFVolume extracts,
  * `run` writes (io::writeMeshPLY) and the rasterizer draws. */
struct TriangleMesh
{
  std::vector<Eigen::Vector3f> vertices;
  std::vector<Eigen::Vector3f> normals;             ///< unit (zero where undefined), empty when none
  std::vector<std::array<std::uint8_t, 3>> colors;  ///< RGB, empty when the file has none
  std::vector<std::uint32_t> labels;                ///< empty when the file has no `label`
  std::vector<Eigen::Vector3i> triangles;
};
}  // namespace cuefusion
