// SPDX-License-Identifier: BSD-3-Clause
// Surface extraction from the TSDF volume: zero-crossing point clouds and marching cubes.
#include "voxel_access.h"

#include <cuefusion/common/parallel.h>
#include <cuefusion/io/mesh_io.h>
#include <cuefusion/reconstruction/tsdf_volume.h>

#include <pcl/surface/marching_cubes.h>  // pcl::edgeTable, pcl::triTable (Bourke's tables)

#include <unordered_map>


namespace cuefusion
{
namespace reconstruction
{
namespace
{
// Cube corners in the order PCL's marching-cubes tables expect.
const std::array<Eigen::Vector3i, 8> kCorner = {Eigen::Vector3i (0, 0, 0), Eigen::Vector3i (1, 0, 0), Eigen::Vector3i (1, 0, 1),
                                               Eigen::Vector3i (0, 0, 1), Eigen::Vector3i (0, 1, 0), Eigen::Vector3i (1, 1, 0),
                                               Eigen::Vector3i (1, 1, 1), Eigen::Vector3i (0, 1, 1)};
// Corners joined by each of the 12 cube edges.
const int kEdge[12][2] = {{0, 1}, {1, 2}, {2, 3}, {3, 0}, {4, 5}, {5, 6}, {6, 7}, {7, 4}, {0, 4}, {1, 5}, {2, 6}, {3, 7}};

/** \brief A surface sample on the edge from voxel a to voxel b. */
struct EdgeSample
{
  Eigen::Vector3f position;
  std::uint8_t r, g, b;
  VoxelNumber nearer;  ///< the voxel nearer the sample (a at t < 0.5)
};

inline EdgeSample
sampleEdge (const TsdfVoxel& a, const TsdfVoxel& b, const Eigen::Vector3f& pa, const Eigen::Vector3f& pb,
            VoxelNumber a_number, VoxelNumber b_number)
{
  const float t = zeroCrossing (a.sdf, b.sdf);
  EdgeSample s;
  s.position = pa + (pb - pa) * t;
  s.r = static_cast<std::uint8_t> (a.r + (b.r - a.r) * t + 0.5f);
  s.g = static_cast<std::uint8_t> (a.g + (b.g - a.g) * t + 0.5f);
  s.b = static_cast<std::uint8_t> (a.b + (b.b - a.b) * t + 0.5f);
  s.nearer = t < 0.5f ? a_number : b_number;
  return s;
}

inline pcl::PointXYZRGBL
toPoint (const EdgeSample& s, const TSDFVolume::VoxelLabelFunction& label_of)
{
  pcl::PointXYZRGBL p;
  p.getVector3fMap () = s.position;
  p.r = s.r;
  p.g = s.g;
  p.b = s.b;
  p.a = 255;
  p.label = label_of ? label_of (s.nearer) : 0u;
  return p;
}

inline bool
observed (const TsdfVoxel* v)
{
  return v != nullptr && v->weight > 0.f;
}

/** \brief Edge key: lower voxel corner (kVoxelCoordinateBits per axis; every voxel of an
  * allocated block fits, voxel_block_hash.h) and the edge's axis. */
inline std::uint64_t
edgeKey (const Eigen::Vector3i& lower, int axis)
{
  constexpr std::uint64_t mask = (std::uint64_t{1} << kVoxelCoordinateBits) - 1;
  constexpr int offset = kVoxelCoordinateLimit;
  return (static_cast<std::uint64_t> (lower.x () + offset) & mask) |
         ((static_cast<std::uint64_t> (lower.y () + offset) & mask) << kVoxelCoordinateBits) |
         ((static_cast<std::uint64_t> (lower.z () + offset) & mask) << (2 * kVoxelCoordinateBits)) |
         (static_cast<std::uint64_t> (axis) << (3 * kVoxelCoordinateBits));
}

/** \brief The lower voxel and the axis of an edge key. */
inline Eigen::Vector3i
edgeLower (std::uint64_t key)
{
  constexpr std::uint64_t mask = (std::uint64_t{1} << kVoxelCoordinateBits) - 1;
  constexpr int offset = kVoxelCoordinateLimit;
  return Eigen::Vector3i (static_cast<int> (key & mask) - offset, static_cast<int> ((key >> kVoxelCoordinateBits) & mask) - offset,
                          static_cast<int> ((key >> (2 * kVoxelCoordinateBits)) & mask) - offset);
}

inline int
edgeAxis (std::uint64_t key)
{
  return static_cast<int> ((key >> (3 * kVoxelCoordinateBits)) & 3u);
}

}  // namespace

void
TSDFVolume::extractPointCloud (pcl::PointCloud<pcl::PointXYZRGBL>& cloud, pcl::PointCloud<pcl::Normal>* normals,
                               const VoxelLabelFunction& label_of) const
{
  const int n = static_cast<int> (store_.size ());
  std::vector<pcl::PointCloud<pcl::PointXYZRGBL>> parts (static_cast<std::size_t> (n));
  std::vector<pcl::PointCloud<pcl::Normal>> normal_parts (normals ? static_cast<std::size_t> (n) : 0);
  parallelForChunks (n, 8, [&] (int, int begin, int end) {
    detail::VoxelAccessor access (*this);
    for (int i = begin; i < end; ++i)
    {
      const VoxelBlock& block = store_.block (static_cast<std::size_t> (i));
      for (int z = 0; z < kBlockSide; ++z)
        for (int y = 0; y < kBlockSide; ++y)
          for (int x = 0; x < kBlockSide; ++x)
          {
            const TsdfVoxel& a = block.voxels[static_cast<std::size_t> (localVoxelIndex (x, y, z))];
            if (!(a.weight > 0.f) || std::abs (a.sdf) >= 1.f)
              continue;
            const Eigen::Vector3i g = block.index * kBlockSide + Eigen::Vector3i (x, y, z);
            for (int axis = 0; axis < 3; ++axis)
            {
              VoxelNumber b_number;
              const TsdfVoxel* b = access.get (g + Eigen::Vector3i::Unit (axis), b_number);
              if (!observed (b) || std::abs (b->sdf) >= 1.f || (a.sdf < 0.f) == (b->sdf < 0.f))
                continue;
              const VoxelNumber a_number = voxelNumber (static_cast<std::size_t> (i), static_cast<std::size_t> (localVoxelIndex (x, y, z)));
              parts[static_cast<std::size_t> (i)].push_back (toPoint (
                  sampleEdge (a, *b, voxelPosition (g), voxelPosition (g + Eigen::Vector3i::Unit (axis)), a_number, b_number),
                  label_of));
              if (normals)
              {
                // TSDF gradient by central differences at the nearer voxel.
                const Eigen::Vector3i c = (a.sdf * a.sdf <= b->sdf * b->sdf) ? g : Eigen::Vector3i (g + Eigen::Vector3i::Unit (axis));
                Eigen::Vector3f grad = Eigen::Vector3f::Zero ();
                bool ok = true;
                for (int k = 0; k < 3 && ok; ++k)
                {
                  const TsdfVoxel* hi = access.get (c + Eigen::Vector3i::Unit (k));
                  const TsdfVoxel* lo = access.get (c - Eigen::Vector3i::Unit (k));
                  ok = observed (hi) && observed (lo);
                  if (ok)
                    grad[k] = hi->sdf - lo->sdf;
                }
                pcl::Normal nrm;
                const float norm = grad.norm ();
                if (ok && norm > 0.f)
                  nrm.getNormalVector3fMap () = grad / norm;
                else
                  nrm.normal_x = nrm.normal_y = nrm.normal_z = std::numeric_limits<float>::quiet_NaN ();
                nrm.curvature = 0.f;
                normal_parts[static_cast<std::size_t> (i)].push_back (nrm);
              }
            }
          }
    }
  });
  cloud.clear ();
  for (const auto& part : parts)
    cloud += part;
  if (normals)
  {
    normals->clear ();
    for (const auto& part : normal_parts)
      *normals += part;
  }
}

TriangleMesh
TSDFVolume::extractTriangleMesh (const VoxelLabelFunction& label_of) const
{
  // Pass 1 (parallel over blocks): for every cube with a surface, the keys of its crossed
  // edges in the tables' edge order, and its triangles as edge keys. Pass 2 (serial, in block
  // order): one vertex per distinct edge, numbered and sampled where it is first met, so
  // neighbouring cubes share it. Keys, not samples, are kept between the passes (8 bytes
  // instead of 32, and each edge is met by up to four cubes): the extraction's peak memory
  // is what `run` peaks at on a large map.
  struct BlockTriangles
  {
    std::vector<std::uint64_t> edges;    // edge key | kReversed when the cube walks it downwards
    std::vector<std::uint64_t> corners;  // 3 edge keys per triangle
  };
  constexpr std::uint64_t kReversed = std::uint64_t (1) << 62;
  const int n = static_cast<int> (store_.size ());
  std::vector<BlockTriangles> parts (static_cast<std::size_t> (n));
  parallelForChunks (n, 8, [&] (int, int begin, int end) {
    detail::VoxelAccessor access (*this);
    for (int i = begin; i < end; ++i)
    {
      const VoxelBlock& block = store_.block (static_cast<std::size_t> (i));
      BlockTriangles& out = parts[static_cast<std::size_t> (i)];
      for (int z = 0; z < kBlockSide; ++z)
        for (int y = 0; y < kBlockSide; ++y)
          for (int x = 0; x < kBlockSide; ++x)
          {
            const Eigen::Vector3i g = block.index * kBlockSide + Eigen::Vector3i (x, y, z);
            bool ok = true;
            int cube = 0;
            for (int k = 0; k < 8 && ok; ++k)
            {
              const TsdfVoxel* c = access.get (g + kCorner[static_cast<std::size_t> (k)]);
              ok = observed (c);
              if (ok && c->sdf < 0.f)
                cube |= 1 << k;
            }
            if (!ok || pcl::edgeTable[cube] == 0)
              continue;
            std::array<std::uint64_t, 12> keys{};
            for (int e = 0; e < 12; ++e)
            {
              if (!(pcl::edgeTable[cube] & (1u << e)))
                continue;
              const Eigen::Vector3i& ca = kCorner[static_cast<std::size_t> (kEdge[e][0])];
              const Eigen::Vector3i& cb = kCorner[static_cast<std::size_t> (kEdge[e][1])];
              int axis = 0;
              while (ca[axis] == cb[axis])
                ++axis;
              keys[static_cast<std::size_t> (e)] = edgeKey (g + ca.cwiseMin (cb), axis);
              out.edges.push_back (keys[static_cast<std::size_t> (e)] | (ca[axis] > cb[axis] ? kReversed : 0));
            }
            for (int t = 0; pcl::triTable[cube][t] != -1; t += 3)
              for (int k = 0; k < 3; ++k)
                out.corners.push_back (keys[static_cast<std::size_t> (pcl::triTable[cube][t + k])]);
          }
    }
  });

  // Vertices numbered where first met; then sampled into a cloud of exactly their number.
  std::unordered_map<std::uint64_t, pcl::index_t> vertex_of;
  std::vector<std::uint64_t> first_met;
  for (auto& part : parts)
  {
    for (const std::uint64_t edge : part.edges)
      if (vertex_of.emplace (edge & ~kReversed, static_cast<pcl::index_t> (first_met.size ())).second)
        first_met.push_back (edge);
    std::vector<std::uint64_t> ().swap (part.edges);
  }
  TriangleMesh mesh;
  mesh.vertices.reserve (first_met.size ());
  mesh.colors.reserve (first_met.size ());
  if (label_of)
    mesh.labels.reserve (first_met.size ());
  {
    detail::VoxelAccessor access (*this);
    for (const std::uint64_t edge : first_met)
    {
      // The sample as the cube that met the edge first takes it: from its corner
      // kEdge[e][0] to kEdge[e][1] (the direction decides rounding and the label at t = 0.5).
      const std::uint64_t key = edge & ~kReversed;
      const Eigen::Vector3i lower = edgeLower (key), upper = lower + Eigen::Vector3i::Unit (edgeAxis (key));
      const Eigen::Vector3i& from = (edge & kReversed) ? upper : lower;
      const Eigen::Vector3i& to = (edge & kReversed) ? lower : upper;
      VoxelNumber from_number, to_number;
      const TsdfVoxel& a = *access.get (from, from_number);
      const TsdfVoxel& b = *access.get (to, to_number);
      const EdgeSample sample = sampleEdge (a, b, voxelPosition (from), voxelPosition (to), from_number, to_number);
      mesh.vertices.push_back (sample.position);
      mesh.colors.push_back ({sample.r, sample.g, sample.b});
      if (label_of)
        mesh.labels.push_back (label_of (sample.nearer));
    }
  }
  std::vector<std::uint64_t> ().swap (first_met);

  std::size_t corner_count = 0;
  for (const auto& part : parts)
    corner_count += part.corners.size ();
  mesh.triangles.reserve (corner_count / 3);
  // Area-weighted triangle normals summed per vertex, normalised below (in place).
  mesh.normals.assign (mesh.vertices.size (), Eigen::Vector3f::Zero ());
  for (auto& part : parts)
  {
    for (std::size_t t = 0; t + 2 < part.corners.size (); t += 3)
    {
      // With "inside" meaning sdf < 0, the table's order winds counter-clockwise seen from
      // outside, so face normals point into free space (checked by the tests).
      const Eigen::Vector3i face (vertex_of.at (part.corners[t]), vertex_of.at (part.corners[t + 1]), vertex_of.at (part.corners[t + 2]));
      if (face[0] == face[1] || face[1] == face[2] || face[0] == face[2])
        continue;
      const Eigen::Vector3f& a = mesh.vertices[static_cast<std::size_t> (face[0])];
      const Eigen::Vector3f& b = mesh.vertices[static_cast<std::size_t> (face[1])];
      const Eigen::Vector3f& c = mesh.vertices[static_cast<std::size_t> (face[2])];
      const Eigen::Vector3f area_normal = (b - a).cross (c - a);
      for (int k = 0; k < 3; ++k)
        mesh.normals[static_cast<std::size_t> (face[k])] += area_normal;
      mesh.triangles.push_back (face);
    }
    std::vector<std::uint64_t> ().swap (part.corners);
  }
  for (Eigen::Vector3f& normal : mesh.normals)
  {
    const float norm = normal.norm ();
    normal = norm > 0.f ? Eigen::Vector3f (normal / norm) : Eigen::Vector3f::Zero ();
  }
  return mesh;
}

pcl::PolygonMesh
TSDFVolume::extractMesh (const VoxelLabelFunction& label_of) const
{
  return io::toPolygonMesh (extractTriangleMesh (label_of));
}
}  // namespace reconstruction
}  // namespace cuefusion
