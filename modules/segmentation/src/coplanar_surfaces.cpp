// SPDX-License-Identifier: BSD-3-Clause
#include "coplanar_surfaces.h"

#include "disjoint_sets.h"

#include <cuefusion/reconstruction/tsdf_volume.h>

#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>

#include <algorithm>
#include <cmath>
#include <map>
#include <unordered_map>

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

/** A plane is fitted to no fewer surface voxels than this (a patch of 3 × 3 voxels). */
constexpr std::size_t kMinPatchVoxels = 9;

/** A plane in voxel units (voxel (i, j, k) is the lattice point (i, j, k)). */
struct Plane
{
  std::uint32_t object = 0;
  Eigen::Vector3d centroid, normal;
};

/** Whether \a v (voxel units) lies within \a tolerance voxels of \a plane. */
inline bool
onPlane (const Plane& plane, const Eigen::Vector3f& v, double tolerance)
{
  return std::abs (plane.normal.dot (v.cast<double> () - plane.centroid)) <= tolerance;
}

/** The object of \a stuff whose surface voxel \a v (label \a label) is: within one voxel of
  * the zero crossing (the surface, not the truncation band around it, which is 2τ thick,
  * eight voxels at the defaults); 0 when it is none's. */
inline std::uint32_t
surfaceObject (const reconstruction::TsdfVoxel& v, std::uint32_t label, const std::vector<std::uint32_t>& shown,
               const std::set<std::uint32_t>& stuff, float near_surface)
{
  if (label == 0 || label >= shown.size () || v.weight <= 0.f || std::abs (v.sdf) > near_surface)
    return 0;
  return stuff.count (shown[label]) ? shown[label] : 0;
}

/** An object's surface voxels (in voxel units); its plane when flat. */
struct StuffSurface
{
  Plane plane;  ///< the object always; centroid and normal when flat
  std::vector<Eigen::Vector3f> points;
  bool flat = false, wide = false;
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

/** Whether kFlatShare of \a points lie within \a tolerance of one plane, fitted to every
  * point, then twice to those within the tolerance of the last fit: the plane in \a plane,
  * the eigenvalues of the inliers' spread, ascending, in \a lambda. */
bool
flatPlane (const std::vector<Eigen::Vector3f>& points, double tolerance, Plane& plane, Eigen::Vector3d& lambda)
{
  if (points.size () < kMinPatchVoxels)
    return false;
  std::vector<char> use (points.size (), 1);
  plane = fitPlane (points, use, lambda);
  for (int round = 0; round < 2; ++round)
  {
    std::size_t inliers = 0;
    for (std::size_t i = 0; i < points.size (); ++i)
      inliers += use[i] = onPlane (plane, points[i], tolerance);
    if (static_cast<double> (inliers) < kFlatShare * static_cast<double> (points.size ()))
      return false;
    plane = fitPlane (points, use, lambda);
  }
  return true;
}

/** The surfaces of the objects of \a stuff, in increasing object order: flat when they lie
  * on a plane (coplanarSurfaces' first test), wide when flat and at least
  * surface_min_extent across in both directions of the plane. */
std::vector<StuffSurface>
stuffSurfaces (const reconstruction::TSDFVolume& volume, const VoxelLabelLayer& labels, const std::vector<std::uint32_t>& shown,
               const std::set<std::uint32_t>& stuff, const GlobalSegmentMapConfig& config)
{
  const float near_surface = static_cast<float> (1.0 / volume.getConfig ().truncation_voxels);
  std::map<std::uint32_t, std::vector<Eigen::Vector3f>> surfaces;  // in voxel units
  const reconstruction::VoxelBlockStore& blocks = volume.store ();
  for (std::size_t id = 0; id < std::min (blocks.size (), labels.blockCount ()); ++id)
  {
    const reconstruction::VoxelBlock& block = blocks.block (id);
    const auto& block_labels = labels.block (id).labels;
    for (int i = 0; i < reconstruction::kBlockVoxels; ++i)
    {
      const std::uint32_t object = surfaceObject (block.voxels[static_cast<std::size_t> (i)],
                                                  block_labels[static_cast<std::size_t> (i)], shown, stuff, near_surface);
      if (object != 0)
        surfaces[object].push_back ((block.index * reconstruction::kBlockSide +
                                     reconstruction::localVoxelPosition (i))
                                        .cast<float> ());
    }
  }
  const double voxel = volume.getConfig ().voxel_size;
  const double tolerance = config.surface_tolerance / voxel, extent = config.surface_min_extent / voxel;
  std::vector<StuffSurface> out;
  for (auto& [object, points] : surfaces)
  {
    StuffSurface surface;
    Eigen::Vector3d lambda;
    surface.flat = flatPlane (points, tolerance, surface.plane, lambda);
    // A rectangle a × b has second moments a²/12 and b²/12 along its sides: the shorter
    // side is √(12 λ₁) long.
    surface.wide = surface.flat && static_cast<double> (points.size ()) >= extent * extent &&
                   std::sqrt (12.0 * lambda (1)) >= extent;
    surface.plane.object = object;
    surface.points = std::move (points);
    out.push_back (std::move (surface));
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

/** Patches of a surface (flat objects narrower than surface_min_extent: a strip of a
  * floor seen only between the slats of a chair's back, a piece of a table top) join the
  * larger surface they touch and that continues their plane: around the patch (within
  * \a extent of its bounds) that surface's voxels within \a tolerance of the patch's plane
  * are at least as many as the patch's and lie on a plane (flatPlane) on which kFlatShare
  * of the patch's voxels lie too, and the pair is not judged. A face that meets a
  * surface at an angle (the side of a box against a wall) selects a strip of that
  * surface, whose plane is the surface's, not the face's. Largest patches first, so that
  * a smaller one can follow through a larger one; each joins the surface it shares the
  * most voxel faces with. */
template <typename Apart, typename Join>
void
joinPatches (const reconstruction::TSDFVolume& volume, const VoxelLabelLayer& labels, const std::vector<std::uint32_t>& shown,
             const std::set<std::uint32_t>& stuff, const std::vector<StuffSurface>& surfaces, double tolerance, double extent,
             DisjointSets& sets, const Apart& apart, const Join& join)
{
  const reconstruction::VoxelBlockStore& blocks = volume.store ();
  const float near_surface = static_cast<float> (1.0 / volume.getConfig ().truncation_voxels);
  std::unordered_map<std::uint32_t, std::size_t> index;  // object → its surface
  for (std::size_t i = 0; i < surfaces.size (); ++i)
    index.emplace (surfaces[i].plane.object, i);
  // The surface whose voxel \a v is (surfaces.size () when none's).
  const auto owner = [&] (const Eigen::Vector3i& v) {
    const reconstruction::VoxelNumber n = blocks.findVoxelNumber (v);
    if (n == reconstruction::kNoVoxel)
      return surfaces.size ();
    const auto it = index.find (surfaceObject (blocks.block (n / reconstruction::kBlockVoxels).voxels[n % reconstruction::kBlockVoxels],
                                               labels.label (n), shown, stuff, near_surface));
    return it == index.end () ? surfaces.size () : it->second;
  };
  std::vector<std::size_t> order;
  for (std::size_t i = 0; i < surfaces.size (); ++i)
    if (surfaces[i].flat && !surfaces[i].wide)
      order.push_back (i);
  std::stable_sort (order.begin (), order.end (),
                    [&] (std::size_t a, std::size_t b) { return surfaces[a].points.size () > surfaces[b].points.size (); });
  const Eigen::Vector3i steps[6] = {{1, 0, 0}, {-1, 0, 0}, {0, 1, 0}, {0, -1, 0}, {0, 0, 1}, {0, 0, -1}};
  for (const std::size_t p : order)
  {
    const std::vector<Eigen::Vector3f>& patch = surfaces[p].points;
    std::map<std::size_t, std::size_t> contacts;  // larger surface → voxel faces it shares with the patch
    Eigen::AlignedBox3f around;
    for (const Eigen::Vector3f& v : patch)
    {
      around.extend (v);
      for (const Eigen::Vector3i& step : steps)
      {
        const std::size_t s = owner (v.cast<int> () + step);
        if (s < surfaces.size () && surfaces[s].points.size () > patch.size ())
          ++contacts[s];
      }
    }
    around.min ().array () -= static_cast<float> (extent);
    around.max ().array () += static_cast<float> (extent);
    const Plane& plane = surfaces[p].plane;
    std::size_t best = p, best_contacts = 0;
    for (const auto& [s, n] : contacts)
    {
      if (n <= best_contacts || sets.find (s) == sets.find (p) || apart (sets.find (s), sets.find (p)))
        continue;
      // The larger surface's voxels around the patch on the patch's plane, and their plane.
      std::vector<Eigen::Vector3f> on_plane;
      for (const Eigen::Vector3f& v : surfaces[s].points)
        if (around.contains (v) && onPlane (plane, v, tolerance))
          on_plane.push_back (v);
      Plane continued;
      Eigen::Vector3d lambda;
      if (on_plane.size () < patch.size () || !flatPlane (on_plane, tolerance, continued, lambda))
        continue;
      std::size_t on = 0;
      for (const Eigen::Vector3f& v : patch)
        on += onPlane (continued, v, tolerance);
      if (static_cast<double> (on) >= kFlatShare * static_cast<double> (patch.size ()))
      {
        best = s;
        best_contacts = n;
      }
    }
    if (best != p)
      join (sets.find (best), sets.find (p));
  }
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
  const std::vector<StuffSurface> surfaces = stuffSurfaces (volume, labels, shown, stuff, config);
  const double tolerance = config.surface_tolerance / volume.getConfig ().voxel_size;
  const double extent = config.surface_min_extent / volume.getConfig ().voxel_size;
  const double min_cos = std::cos (config.surface_max_angle_deg * M_PI / 180.0);
  // Groups never hold a pair the evidence judged, not even through a third surface.
  DisjointSets sets (surfaces.size ());
  std::vector<std::vector<std::size_t>> members (surfaces.size ());  // by root
  for (std::size_t i = 0; i < surfaces.size (); ++i)
    members[i] = {i};
  const auto apart = [&] (std::size_t ra, std::size_t rb) {
    for (const std::size_t x : members[ra])
      for (const std::size_t y : members[rb])
        if (judged.count ({std::min (surfaces[x].plane.object, surfaces[y].plane.object),
                           std::max (surfaces[x].plane.object, surfaces[y].plane.object)}))
          return true;
    return false;
  };
  const auto join = [&] (std::size_t ra, std::size_t rb) {
    sets.join (ra, rb);
    members[ra].insert (members[ra].end (), members[rb].begin (), members[rb].end ());
    members[rb].clear ();
  };
  for (std::size_t i = 0; i < surfaces.size (); ++i)
    for (std::size_t j = i + 1; j < surfaces.size (); ++j)
    {
      if (!surfaces[i].wide || !surfaces[j].wide)
        continue;
      const Plane &a = surfaces[i].plane, &b = surfaces[j].plane;
      const Eigen::Vector3d d = b.centroid - a.centroid;
      const std::size_t ra = sets.find (i), rb = sets.find (j);
      if (ra == rb || std::abs (a.normal.dot (b.normal)) < min_cos || std::abs (a.normal.dot (d)) > tolerance ||
          std::abs (b.normal.dot (d)) > tolerance || apart (ra, rb) || somethingBetween (volume, labels, shown, a, b, tolerance, extent))
        continue;
      join (ra, rb);
    }
  joinPatches (volume, labels, shown, stuff, surfaces, tolerance, extent, sets, apart, join);
  // Each group under its smallest object (surfaces come in increasing object order).
  const std::vector<std::size_t> roots = sets.roots ();
  std::map<std::size_t, std::uint32_t> root_object;
  for (std::size_t i = 0; i < surfaces.size (); ++i)
    root_object.emplace (roots[i], surfaces[i].plane.object);
  for (std::size_t i = 0; i < surfaces.size (); ++i)
    if (root_object.at (roots[i]) != surfaces[i].plane.object)
      out[surfaces[i].plane.object] = root_object.at (roots[i]);
  return out;
}
}  // namespace detail
}  // namespace segmentation
}  // namespace cuefusion
