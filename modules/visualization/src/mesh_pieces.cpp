// SPDX-License-Identifier: BSD-3-Clause
#include <cuefusion/visualization/mesh_pieces.h>

#include <numeric>
#include <vector>

namespace cuefusion
{
namespace visualization
{
TriangleMesh
withoutSmallPieces (const TriangleMesh& mesh, std::size_t min_triangles)
{
  if (min_triangles <= 1)
    return mesh;
  // Union–find over the vertices: a triangle joins its three.
  std::vector<std::size_t> parent (mesh.vertices.size ());
  std::iota (parent.begin (), parent.end (), std::size_t{0});
  const auto find = [&parent] (std::size_t i) {
    while (parent[i] != i)
      i = parent[i] = parent[parent[i]];
    return i;
  };
  const auto valid = [&mesh] (const Eigen::Vector3i& t) {
    for (int k = 0; k < 3; ++k)
      if (t[k] < 0 || static_cast<std::size_t> (t[k]) >= mesh.vertices.size ())
        return false;
    return true;
  };
  for (const Eigen::Vector3i& t : mesh.triangles)
    if (valid (t))
      for (int k = 1; k < 3; ++k)
        parent[find (static_cast<std::size_t> (t[k]))] = find (static_cast<std::size_t> (t[0]));
  std::vector<std::size_t> triangles_of (mesh.vertices.size (), 0);  // by root
  for (const Eigen::Vector3i& t : mesh.triangles)
    if (valid (t))
      ++triangles_of[find (static_cast<std::size_t> (t[0]))];
  TriangleMesh out = mesh;
  out.triangles.clear ();
  for (const Eigen::Vector3i& t : mesh.triangles)
    if (valid (t) && triangles_of[find (static_cast<std::size_t> (t[0]))] >= min_triangles)
      out.triangles.push_back (t);
  return out;
}
}  // namespace visualization
}  // namespace cuefusion
