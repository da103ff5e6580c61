// SPDX-License-Identifier: BSD-3-Clause
#include "coplanar_surfaces.h"

#include "disjoint_sets.h"

#include <cuefusion/reconstruction/tsdf_volume.h>

#include <Eigen/Eigenvalues>

#include <algorithm>
#include <cmath>
#include <map>

namespace cuefusion
{
namespace segmentation
{
namespace detail
{
namespace
{
/** A flat surface holds at least this share of its surface voxels within
  * GlobalSegmentMapConfig::surface_tolerance of its plane (the rest: the feet of a chair
  * on a floor, a switch on a wall, fragments settled into it). */
constexpr double kFlatShare = 0.9;

/** A plane in voxel units (voxel (i, j, k) is the lattice point (i, j, k)). */
struct Plane
{
  std::uint32_t object = 0;
  Eigen::Vector3d centroid, normal;
};

/** The plane of the \a points marked in \a use, and the eigenvalues of their spread,
  * ascending, in \a lambda. */
Plane
fitPlane (const std::vector<Eigen::Vector3f>& points, const std::vector<char>& use, Eigen::Vector3d& lambda)
{
  // Sums in double: a room is 10^5 voxels of coordinates in the hundreds, squared.
  std::size_t n = 0;
  Eigen::Vector3d sum = Eigen::Vector3d::Zero ();
  Eigen::Matrix3d outer = Eigen::Matrix3d::Zero ();
  for (std::size_t i = 0; i < points.size (); ++i)
    if (use[i])
    {
      const Eigen::Vector3d p = points[i].cast<double> ();
      ++n;
      sum += p;
      outer += p * p.transpose ();
    }
  const double count = static_cast<double> (std::max<std::size_t> (n, 1));
  Plane plane;
  plane.centroid = sum / count;
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> solver (outer / count - plane.centroid * plane.centroid.transpose ());
  lambda = solver.eigenvalues ().cwiseMax (0.0);
  plane.normal = solver.eigenvectors ().col (0);
  return plane;
}

/** The objects of \a stuff whose surface lies on a plane (coplanarSurfaces' first test). */
std::vector<Plane>
flatSurfaces (const reconstruction::TSDFVolume& volume, const VoxelLabelLayer& labels, const std::vector<std::uint32_t>& shown,
              const std::set<std::uint32_t>& stuff, const GlobalSegmentMapConfig& config)
{
  // Voxels within one voxel of the zero crossing: the surface, not the truncation band
  // around it (the band is 2τ thick, eight voxels at the defaults).
  const float near_surface = static_cast<float> (1.0 / volume.getConfig ().truncation_voxels);
  std::map<std::uint32_t, std::vector<Eigen::Vector3f>> surfaces;  // in voxel units
  const reconstruction::VoxelBlockStore& blocks = volume.store ();
  for (std::size_t id = 0; id < std::min (blocks.size (), labels.blockCount ()); ++id)
  {
    const reconstruction::VoxelBlock& block = blocks.block (id);
    const auto& block_labels = labels.block (id).labels;
    for (int i = 0; i < reconstruction::kBlockVoxels; ++i)
    {
      const std::uint32_t label = block_labels[static_cast<std::size_t> (i)];
      const reconstruction::TsdfVoxel& v = block.voxels[static_cast<std::size_t> (i)];
      if (label == 0 || label >= shown.size () || v.weight <= 0.f || std::abs (v.sdf) > near_surface)
        continue;
      const std::uint32_t object = shown[label];
      if (object != 0 && stuff.count (object))
        surfaces[object].push_back ((block.index * reconstruction::kBlockSide +
                                     reconstruction::localVoxelPosition (i))
                                        .cast<float> ());
    }
  }
  const double voxel = volume.getConfig ().voxel_size;
  const double tolerance = config.surface_tolerance / voxel, extent = config.surface_min_extent / voxel;
  std::vector<Plane> out;
  for (const auto& [object, points] : surfaces)
  {
    if (static_cast<double> (points.size ()) < extent * extent)
      continue;
    // Fitted to every voxel, then twice to those within the tolerance of the last fit.
    std::vector<char> use (points.size (), 1);
    Eigen::Vector3d lambda;
    Plane plane = fitPlane (points, use, lambda);
    bool flat = true;
    for (int round = 0; round < 2 && flat; ++round)
    {
      std::size_t inliers = 0;
      for (std::size_t i = 0; i < points.size (); ++i)
        inliers += use[i] = std::abs (plane.normal.dot (points[i].cast<double> () - plane.centroid)) <= tolerance;
      flat = static_cast<double> (inliers) >= kFlatShare * static_cast<double> (points.size ());
      if (flat)
        plane = fitPlane (points, use, lambda);
    }
    // A rectangle a × b has second moments a²/12 and b²/12 along its sides: the shorter
    // side is √(12 λ₁) long.
    if (!flat || std::sqrt (12.0 * lambda (1)) < extent)
      continue;
    plane.object = object;
    out.push_back (plane);
  }
  return out;
}

/** Whether something lies on the plane between \a a and \a b, along the line between
  * their centroids: free space (more than \a tolerance voxels observed and further than
  * \a tolerance from every surface: a gap a camera looked through) or another object's
  * surface (more than \a extent voxels within \a tolerance of a surface that shows as
  * neither: a surface of its own between them, such as a third door between two). */
bool
somethingBetween (const reconstruction::TSDFVolume& volume, const VoxelLabelLayer& labels, const std::vector<std::uint32_t>& shown,
                  const Plane& a, const Plane& b, double tolerance, double extent)
{
  const reconstruction::VoxelBlockStore& blocks = volume.store ();
  const double truncation = volume.getConfig ().truncation_voxels;
  const float free_sdf = static_cast<float> (std::min (1.0, tolerance / truncation)), on_surface = static_cast<float> (tolerance / truncation);
  const Eigen::Vector3d step = b.centroid - a.centroid;
  const int samples = static_cast<int> (std::ceil (step.norm ()));
  int free = 0, other = 0;
  for (int s = 1; s < samples; ++s)
  {
    const Eigen::Vector3d p = a.centroid + step * (static_cast<double> (s) / samples);
    const reconstruction::VoxelNumber n = blocks.findVoxelNumber (reconstruction::nearestVoxel (p.cast<float> ()));
    if (n == reconstruction::kNoVoxel)
      continue;
    const reconstruction::TsdfVoxel& v = blocks.block (n / reconstruction::kBlockVoxels).voxels[n % reconstruction::kBlockVoxels];
    if (v.weight <= 0.f)
      continue;
    if (v.sdf > free_sdf && ++free > tolerance)
      return true;
    const std::uint32_t label = labels.label (n);
    const std::uint32_t object = label < shown.size () ? shown[label] : 0;
    if (std::abs (v.sdf) <= on_surface && object != 0 && object != a.object && object != b.object && ++other > extent)
      return true;
  }
  return false;
}
}  // namespace

std::unordered_map<std::uint32_t, std::uint32_t>
coplanarSurfaces (const reconstruction::TSDFVolume& volume, const VoxelLabelLayer& labels, const std::vector<std::uint32_t>& shown,
                  const std::set<std::uint32_t>& stuff, const std::set<std::pair<std::uint32_t, std::uint32_t>>& judged,
                  const GlobalSegmentMapConfig& config)
{
  std::unordered_map<std::uint32_t, std::uint32_t> out;
  if (config.surface_min_extent <= 0.f || stuff.size () < 2)
    return out;
  const std::vector<Plane> planes = flatSurfaces (volume, labels, shown, stuff, config);
  const double tolerance = config.surface_tolerance / volume.getConfig ().voxel_size;
  const double extent = config.surface_min_extent / volume.getConfig ().voxel_size;
  const double min_cos = std::cos (config.surface_max_angle_deg * M_PI / 180.0);
  // Groups never hold a pair the evidence judged, not even through a third surface.
  DisjointSets sets (planes.size ());
  std::vector<std::vector<std::size_t>> members (planes.size ());  // by root
  for (std::size_t i = 0; i < planes.size (); ++i)
    members[i] = {i};
  const auto apart = [&] (std::size_t ra, std::size_t rb) {
    for (const std::size_t x : members[ra])
      for (const std::size_t y : members[rb])
        if (judged.count ({std::min (planes[x].object, planes[y].object), std::max (planes[x].object, planes[y].object)}))
          return true;
    return false;
  };
  for (std::size_t i = 0; i < planes.size (); ++i)
    for (std::size_t j = i + 1; j < planes.size (); ++j)
    {
      const Plane &a = planes[i], &b = planes[j];
      const Eigen::Vector3d d = b.centroid - a.centroid;
      const std::size_t ra = sets.find (i), rb = sets.find (j);
      if (ra == rb || std::abs (a.normal.dot (b.normal)) < min_cos || std::abs (a.normal.dot (d)) > tolerance ||
          std::abs (b.normal.dot (d)) > tolerance || apart (ra, rb) || somethingBetween (volume, labels, shown, a, b, tolerance, extent))
        continue;
      sets.join (ra, rb);
      members[ra].insert (members[ra].end (), members[rb].begin (), members[rb].end ());
      members[rb].clear ();
    }
  // Each group under its smallest object (planes come in increasing object order).
  const std::vector<std::size_t> roots = sets.roots ();
  std::map<std::size_t, std::uint32_t> root_object;
  for (std::size_t i = 0; i < planes.size (); ++i)
    root_object.emplace (roots[i], planes[i].object);
  for (std::size_t i = 0; i < planes.size (); ++i)
    if (root_object.at (roots[i]) != planes[i].object)
      out[planes[i].object] = root_object.at (roots[i]);
  return out;
}
}  // namespace detail
}  // namespace segmentation
}  // namespace cuefusion
