// SPDX-License-Identifier: BSD-3-Clause
#pragma once

#include <cuefusion/common/triangle_mesh.h>

#include <cstddef>

namespace cuefusion
{
namespace visualization
{
/** \brief \a mesh without its connected pieces (triangles joined through shared vertices)
  * of fewer than \a min_triangles triangles: the specks a surface seen a few times from
  * far away leaves in a TSDF mesh, which a render shows as confetti. Vertices are kept
  * (unused ones are harmless to the rasterizer); 0 keeps every piece. Open3D's
  * cluster_connected_triangles does the same for its meshes.
  */
TriangleMesh
withoutSmallPieces (const TriangleMesh& mesh, std::size_t min_triangles);
}  // namespace visualization
}  // namespace cuefusion
