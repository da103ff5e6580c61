// Surface extraction from the TSDF volume: zero-crossing point clouds and marching cubes.
#include "voxel_access.h"

#include <cuefusion/common/parallel.h>
#include <cuefusion/reconstruction/tsdf_volume.h>

#include <pcl/common/io.h>
#include <pcl/conversions.h>
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
  std::uint32_t label;
};

inline EdgeSample
sampleEdge (const TsdfVoxel& a, const TsdfVoxel& b, const Eigen::Vector3f& pa, const Eigen::Vector3f& pb)
{
  const float t = zeroCrossing (a.sdf, b.sdf);
  EdgeSample s;
  s.position = pa + (pb - pa) * t;
  s.r = static_cast<std::uint8_t> (a.r + (b.r - a.r) * t + 0.5f);
  s.g = static_cast<std::uint8_t> (a.g + (b.g - a.g) * t + 0.5f);
  s.b = static_cast<std::uint8_t> (a.b + (b.b - a.b) * t + 0.5f);
  s.label = t < 0.5f ? a.label : b.label;
  return s;
}

inline pcl::PointXYZRGBL
toPoint (const EdgeSample& s)
{
  pcl::PointXYZRGBL p;
  p.getVector3fMap () = s.position;
  p.r = s.r;
  p.g = s.g;
  p.b = s.b;
  p.a = 255;
  p.label = s.label;
  return p;
}

inline bool
observed (const TsdfVoxel* v)
{
  return v != nullptr && v->weight > 0.f;
}

/** \brief Edge key: lower voxel corner (20 bits per axis) and the edge's axis. */
inline std::uint64_t
edgeKey (const Eigen::Vector3i& lower, int axis)
{
  constexpr std::uint64_t mask = (1u << 20) - 1;
  constexpr int offset = 1 << 19;
  return (static_cast<std::uint64_t> (lower.x () + offset) & mask) |
         ((static_cast<std::uint64_t> (lower.y () + offset) & mask) << 20) |
         ((static_cast<std::uint64_t> (lower.z () + offset) & mask) << 40) | (static_cast<std::uint64_t> (axis) << 60);
}

/** \brief The lower voxel and the axis of an edge key. */
inline Eigen::Vector3i
edgeLower (std::uint64_t key)
{
  constexpr std::uint64_t mask = (1u << 20) - 1;
  constexpr int offset = 1 << 19;
  return Eigen::Vector3i (static_cast<int> (key & mask) - offset, static_cast<int> ((key >> 20) & mask) - offset,
                          static_cast<int> ((key >> 40) & mask) - offset);
}

inline int
edgeAxis (std::uint64_t key)
{
  return static_cast<int> ((key >> 60) & 3u);
}

/** \brief The mesh's vertex cloud: positions, colour, label, then normals. Each input is
  * released once converted, so the three blobs are never all alive beside both clouds. */
pcl::PCLPointCloud2
toMeshCloud (pcl::PointCloud<pcl::PointXYZRGBL>&& points, pcl::PointCloud<pcl::Normal>&& normals)
{
  pcl::PCLPointCloud2 a, b, out;
  pcl::toPCLPointCloud2 (points, a);
  pcl::PointCloud<pcl::PointXYZRGBL> ().swap (points);
  pcl::toPCLPointCloud2 (normals, b);
  pcl::PointCloud<pcl::Normal> ().swap (normals);
  pcl::concatenateFields (a, b, out);
  return out;
}
}  // namespace

void
TSDFVolume::extractPointCloud (pcl::PointCloud<pcl::PointXYZRGBL>& cloud, pcl::PointCloud<pcl::Normal>* normals) const
{
  const int n = static_cast<int> (blocks_.size ());
  std::vector<pcl::PointCloud<pcl::PointXYZRGBL>> parts (static_cast<std::size_t> (n));
  std::vector<pcl::PointCloud<pcl::Normal>> normal_parts (normals ? static_cast<std::size_t> (n) : 0);
  parallelForChunks (n, 8, [&] (int, int begin, int end) {
    detail::VoxelAccessor access (*this);
    for (int i = begin; i < end; ++i)
    {
      const VoxelBlock& block = *blocks_[static_cast<std::size_t> (i)];
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
              const TsdfVoxel* b = access.get (g + Eigen::Vector3i::Unit (axis));
              if (!observed (b) || std::abs (b->sdf) >= 1.f || (a.sdf < 0.f) == (b->sdf < 0.f))
                continue;
              parts[static_cast<std::size_t> (i)].push_back (
                toPoint (sampleEdge (a, *b, voxelPosition (g), voxelPosition (g + Eigen::Vector3i::Unit (axis)))));
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

pcl::PolygonMesh
TSDFVolume::extractMesh () const
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
  const int n = static_cast<int> (blocks_.size ());
  std::vector<BlockTriangles> parts (static_cast<std::size_t> (n));
  parallelForChunks (n, 8, [&] (int, int begin, int end) {
    detail::VoxelAccessor access (*this);
    for (int i = begin; i < end; ++i)
    {
      const VoxelBlock& block = *blocks_[static_cast<std::size_t> (i)];
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

  pcl::PointCloud<pcl::PointXYZRGBL> points;
  std::unordered_map<std::uint64_t, pcl::index_t> vertex_of;
  {
    detail::VoxelAccessor access (*this);
    for (auto& part : parts)
    {
      for (const std::uint64_t edge : part.edges)
      {
        const std::uint64_t key = edge & ~kReversed;
        if (!vertex_of.emplace (key, static_cast<pcl::index_t> (points.size ())).second)
          continue;
        // The sample as the cube that met the edge first takes it: from its corner
        // kEdge[e][0] to kEdge[e][1] (the direction decides rounding and the label at t = 0.5).
        const Eigen::Vector3i lower = edgeLower (key), upper = lower + Eigen::Vector3i::Unit (edgeAxis (key));
        const Eigen::Vector3i& from = (edge & kReversed) ? upper : lower;
        const Eigen::Vector3i& to = (edge & kReversed) ? lower : upper;
        points.push_back (toPoint (sampleEdge (*access.get (from), *access.get (to), voxelPosition (from), voxelPosition (to))));
      }
      std::vector<std::uint64_t> ().swap (part.edges);
    }
  }

  pcl::PolygonMesh mesh;
  std::size_t corner_count = 0;
  for (const auto& part : parts)
    corner_count += part.corners.size ();
  mesh.polygons.reserve (corner_count / 3);
  std::vector<Eigen::Vector3f> accumulated (points.size (), Eigen::Vector3f::Zero ());
  for (auto& part : parts)
  {
    for (std::size_t t = 0; t + 2 < part.corners.size (); t += 3)
    {
      pcl::Vertices face;
      // With "inside" meaning sdf < 0, the table's order winds counter-clockwise seen from
      // outside, so face normals point into free space (checked by the tests).
      face.vertices = {vertex_of.at (part.corners[t]), vertex_of.at (part.corners[t + 1]), vertex_of.at (part.corners[t + 2])};
      if (face.vertices[0] == face.vertices[1] || face.vertices[1] == face.vertices[2] || face.vertices[0] == face.vertices[2])
        continue;
      const Eigen::Vector3f a = points[static_cast<std::size_t> (face.vertices[0])].getVector3fMap ();
      const Eigen::Vector3f b = points[static_cast<std::size_t> (face.vertices[1])].getVector3fMap ();
      const Eigen::Vector3f c = points[static_cast<std::size_t> (face.vertices[2])].getVector3fMap ();
      const Eigen::Vector3f area_normal = (b - a).cross (c - a);
      for (const pcl::index_t v : face.vertices)
        accumulated[static_cast<std::size_t> (v)] += area_normal;
      mesh.polygons.push_back (std::move (face));
    }
    std::vector<std::uint64_t> ().swap (part.corners);
  }
  std::unordered_map<std::uint64_t, pcl::index_t> ().swap (vertex_of);
  std::vector<BlockTriangles> ().swap (parts);
  pcl::PointCloud<pcl::Normal> normals;
  normals.resize (points.size ());
  for (std::size_t i = 0; i < points.size (); ++i)
  {
    const float norm = accumulated[i].norm ();
    normals[i].getNormalVector3fMap () = norm > 0.f ? Eigen::Vector3f (accumulated[i] / norm) : Eigen::Vector3f::Zero ();
    normals[i].curvature = 0.f;
  }
  std::vector<Eigen::Vector3f> ().swap (accumulated);
  mesh.cloud = toMeshCloud (std::move (points), std::move (normals));
  return mesh;
}
}  // namespace reconstruction
}  // namespace cuefusion
