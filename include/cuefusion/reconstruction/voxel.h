// SPDX-License-Identifier: BSD-3-Clause
#pragma once

#include <cuefusion/common/fast_math.h>

#include <Eigen/Core>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>

namespace cuefusion
{
namespace reconstruction
{
/** \brief One voxel of the TSDF volume (12 bytes).
  *
  * sdf is the truncated signed distance in units of the truncation distance, in [-1, 1]
  * (positive in front of the surface). weight is the fusion weight of §4.1.4, capped at
  * w_max. r, g, b are the fused colour. Nothing else lives here: what other layers keep
  * per voxel (the segmentation's labels, segmentation::VoxelLabelLayer) they keep in
  * their own storage under the voxel's number (VoxelNumber), as voxblox keeps its label
  * layer beside its TSDF layer.
  */
struct TsdfVoxel
{
  float sdf = 1.f;
  float weight = 0.f;
  std::uint8_t r = 0, g = 0, b = 0;
  std::uint8_t reserved = 0;  ///< keeps the colour a 32-bit word (the AVX2 integration reads it as one)
};
static_assert (sizeof (TsdfVoxel) == 12, "TsdfVoxel is meant to stay 12 bytes");

/** \brief Voxels per block side; a block is 8³ voxels as in InfiniTAM. */
constexpr int kBlockSide = 8;
constexpr int kBlockVoxels = kBlockSide * kBlockSide * kBlockSide;

/** \brief A voxel's number in a volume: its block's id (the position in
  * VoxelBlockStore, which never changes while the block lives) × kBlockVoxels + its
  * index in the block (localVoxelIndex). Layers beside the TSDF key their data by it;
  * SurfaceObservation, RaycastResult::voxels and the extraction's label lookups carry it.
  */
using VoxelNumber = std::uint32_t;
constexpr VoxelNumber kNoVoxel = 0xffffffffu;  ///< "no voxel" (−1 in a CV_32S image)

inline VoxelNumber
voxelNumber (std::size_t block_id, std::size_t local)
{
  return static_cast<VoxelNumber> (block_id * static_cast<std::size_t> (kBlockVoxels) + local);
}

/** \brief The distance layer's marker for a voxel no measurement has reached. */
constexpr std::int16_t kUnobservedDistance = -32768;
constexpr float kDistanceScale = 32767.f;

/** \brief A voxel's distance in the compact layer: sdf · 32767 rounded (1.2 µm steps at
  * τ = 4 cm), or kUnobservedDistance while its weight is 0.
  */
inline std::int16_t
encodeDistance (const TsdfVoxel& voxel)
{
  if (!(voxel.weight > 0.f))
    return kUnobservedDistance;
  const float s = std::clamp (voxel.sdf, -1.f, 1.f) * kDistanceScale;
  return static_cast<std::int16_t> (s >= 0.f ? s + 0.5f : s - 0.5f);
}

inline float
decodeDistance (std::int16_t d)
{
  return static_cast<float> (d) / kDistanceScale;
}

/** \brief Linear index of local voxel (x, y, z) inside its block. */
inline int
localVoxelIndex (int x, int y, int z)
{
  return x + kBlockSide * (y + kBlockSide * z);
}

/** \brief Local voxel (x, y, z) of linear index \a i inside its block (localVoxelIndex's inverse). */
inline Eigen::Vector3i
localVoxelPosition (int i)
{
  return {i % kBlockSide, (i / kBlockSide) % kBlockSide, i / (kBlockSide * kBlockSide)};
}

/** \brief Side of a block's distance layer: its 8 voxels plus a one-voxel apron that
  * mirrors the neighbouring blocks' first layer on the positive side.
  */
constexpr int kDistanceSide = kBlockSide + 1;
constexpr int kDistanceCount = kDistanceSide * kDistanceSide * kDistanceSide;

/** \brief Index of local voxel (x, y, z), each in [0, kBlockSide], in a distance layer;
  * a coordinate of kBlockSide is the apron (see VoxelBlock).
  */
inline int
distanceIndex (int x, int y, int z)
{
  return x + kDistanceSide * (y + kDistanceSide * z);
}

/** \brief 8³ voxels and a compact copy of their distances.
  *
  * The ray caster reads only distances, and reading them from the 12-byte voxels costs a
  * cell of 2×2×2 voxels four cache lines; the 2-byte copy mostly fits one, and a whole
  * block's distances are 1.4 KiB instead of 6. The copy is 9³: besides the block's own
  * voxels it holds an apron, a copy of the distances of the voxels one past its positive
  * faces, edges and corner, which belong to the seven neighbouring blocks on the positive
  * side (kUnobservedDistance where such a block is not allocated). So every 2×2×2 cell
  * the ray caster reads lies in the layer of its lower corner's block: a third of all
  * cells straddle blocks, and reading those from two to eight blocks was a seventh of
  * the raycast on 7-Scenes.
  *
  * TSDFVolume keeps all of it in step: integrate() writes the own voxels' distances and
  * copies them into the neighbours' aprons, a new block takes its apron from the
  * neighbours already there (VoxelBlockStore::allocate), and load() rebuilds both. Code
  * that writes sdf or weight directly must call VoxelBlockStore::refreshDistances().
  */
struct VoxelBlock
{
  alignas (64) std::array<std::int16_t, kDistanceCount> distances;  ///< see distanceIndex ()
  Eigen::Vector3i index = Eigen::Vector3i::Zero ();  ///< block coordinates (voxel index / 8)
  std::array<TsdfVoxel, kBlockVoxels> voxels;

  VoxelBlock () { distances.fill (kUnobservedDistance); }

  /** \brief Rebuilds the own voxels' distances (not the apron, which its neighbours own). */
  void
  refreshDistances ()
  {
    for (int z = 0; z < kBlockSide; ++z)
      for (int y = 0; y < kBlockSide; ++y)
        for (int x = 0; x < kBlockSide; ++x)
          distances[static_cast<std::size_t> (distanceIndex (x, y, z))] =
              encodeDistance (voxels[static_cast<std::size_t> (localVoxelIndex (x, y, z))]);
  }
};

/** \brief Copies the distances of the voxels on \a upper's lower faces into \a lower's apron,
  * where \a upper is the block at \a lower's index + (J & 1, (J >> 1) & 1, (J >> 2) & 1),
  * 1 ≤ J ≤ 7: one face (J = 1, 2, 4), edge (3, 5, 6) or the corner (7). The shape is a
  * template argument so that the row copies compile to fixed-size moves (with a run-time
  * length they were a library call per row, 64 of them for the x face).
  */
template <int J>
inline void
copyApron (const VoxelBlock& upper, VoxelBlock& lower)
{
  static_assert (J >= 1 && J <= 7, "J names one of the seven neighbours on the positive side");
  constexpr bool ox = J & 1, oy = (J >> 1) & 1, oz = (J >> 2) & 1;
  constexpr int nx = ox ? 1 : kBlockSide, ny = oy ? 1 : kBlockSide, nz = oz ? 1 : kBlockSide;
  for (int z = 0; z < nz; ++z)
    for (int y = 0; y < ny; ++y)
    {
      const std::int16_t* from = &upper.distances[static_cast<std::size_t> (distanceIndex (0, y, z))];
      std::int16_t* to = &lower.distances[static_cast<std::size_t> (
          distanceIndex (ox ? kBlockSide : 0, oy ? kBlockSide : y, oz ? kBlockSide : z))];
      std::copy (from, from + nx, to);
    }
}

/** \brief copyApron<j> (upper, lower) for a run-time \a j in [1, 7]. */
inline void
copyApron (const VoxelBlock& upper, VoxelBlock& lower, int j)
{
  switch (j)
  {
    case 1: copyApron<1> (upper, lower); break;
    case 2: copyApron<2> (upper, lower); break;
    case 3: copyApron<3> (upper, lower); break;
    case 4: copyApron<4> (upper, lower); break;
    case 5: copyApron<5> (upper, lower); break;
    case 6: copyApron<6> (upper, lower); break;
    case 7: copyApron<7> (upper, lower); break;
    default: break;
  }
}

/** \brief A voxel that the last integrated frame saw inside the truncation band of the
  * surface (TSDFVolume::setRecordObservedSurface): updated by that frame, |z − D(u)| < τ at
  * the nearest pixel and |sdf| < 1 after the update. The label update of §4.2.4 walks
  * these instead of projecting every voxel of the frame's blocks a second time.
  */
struct SurfaceObservation
{
  VoxelNumber voxel = 0;    ///< the voxel's number (block id × kBlockVoxels + its index in the block)
  std::uint32_t pixel = 0;  ///< nearest pixel the voxel projects to: v << 16 | u
  float gap = 0.f;          ///< |z_voxel − D(u)| at that pixel, metres (< truncation)
  float sdf = 0.f;          ///< the voxel's fused distance after this frame (truncation units, |sdf| < 1)
};

using ::cuefusion::fastFloor;

inline Eigen::Vector3i
fastFloor (const Eigen::Vector3f& p)
{
  return {fastFloor (p.x ()), fastFloor (p.y ()), fastFloor (p.z ())};
}

/** \brief Nearest lattice point of continuous voxel coordinates. */
inline Eigen::Vector3i
nearestVoxel (const Eigen::Vector3f& g)
{
  return fastFloor (Eigen::Vector3f (g.array () + 0.5f));
}

inline Eigen::Vector3i
blockOfVoxel (const Eigen::Vector3i& v)
{
  static_assert (kBlockSide == 8, "blockOfVoxel shifts by log2(kBlockSide)");
  // Arithmetic right shift is floor division by 8 for negative indices too.
  return {v.x () >> 3, v.y () >> 3, v.z () >> 3};
}

/** \brief §4.1.4: weighted running average of the truncated distance (and colour), the
  * weight growing by one per observation up to \a max_weight. \a tsdf is the new
  * observation in truncation units, already clamped to ≤ 1.
  */
inline void
updateVoxel (TsdfVoxel& voxel, float tsdf, const std::uint8_t* bgr, float max_weight)
{
  const float w = voxel.weight;
  const float w_new = w + 1.f;
  voxel.sdf = (w * voxel.sdf + tsdf) / w_new;
  if (bgr != nullptr)
  {
    voxel.r = static_cast<std::uint8_t> ((w * voxel.r + bgr[2]) / w_new + 0.5f);
    voxel.g = static_cast<std::uint8_t> ((w * voxel.g + bgr[1]) / w_new + 0.5f);
    voxel.b = static_cast<std::uint8_t> ((w * voxel.b + bgr[0]) / w_new + 0.5f);
  }
  voxel.weight = std::min (w_new, max_weight);
}

/** \brief Projective truncated distance of a voxel at camera-frame depth \a voxel_z seen
  * by a measurement \a depth, in truncation units; false when the voxel lies further than
  * one truncation distance behind the surface (unobserved, left untouched).
  */
inline bool
projectiveTsdf (float depth, float voxel_z, float truncation, float& tsdf)
{
  const float sdf = depth - voxel_z;
  if (sdf < -truncation)
    return false;
  tsdf = std::min (1.f, sdf / truncation);
  return true;
}

/** \brief a + (b − a) · t, for one value (T = float) or eight (T = __m256, with GCC's
  * vector arithmetic): the ray caster's scalar and eight-ray paths share these formulas,
  * so both give the same bits. Always inlined, so that an eight-lane use compiles in its
  * caller's AVX2 context.
  */
// Eight-lane values passed by value in a file compiled without AVX would change the ABI,
// GCC notes; these are always inlined into their AVX2 callers, so no call passes one.
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wpsabi"
template <typename T>
__attribute__ ((always_inline)) inline T
blend (T a, T b, T t)
{
  return a + (b - a) * t;
}

/** \brief Trilinear blend of eight corner values c[i], corner i = (i&1, (i>>1)&1, (i>>2)&1),
  * at the fractions (fx, fy, fz) of the cell; T as for blend. */
template <typename T>
__attribute__ ((always_inline)) inline T
trilinearBlend (const T* c, T fx, T fy, T fz)
{
  const T x0 = blend (c[0], c[1], fx), x1 = blend (c[2], c[3], fx), x2 = blend (c[4], c[5], fx), x3 = blend (c[6], c[7], fx);
  return blend (blend (x0, x1, fy), blend (x2, x3, fy), fz);
}

/** \brief The gradient of trilinearBlend within the cell (per unit of fraction); T as for
  * blend. */
template <typename T>
__attribute__ ((always_inline)) inline void
trilinearGradient (const T* c, T fx, T fy, T fz, T& gx, T& gy, T& gz)
{
  gx = blend (blend (c[1] - c[0], c[3] - c[2], fy), blend (c[5] - c[4], c[7] - c[6], fy), fz);
  gy = blend (blend (c[2] - c[0], c[3] - c[1], fx), blend (c[6] - c[4], c[7] - c[5], fx), fz);
  gz = blend (blend (c[4] - c[0], c[5] - c[1], fx), blend (c[6] - c[2], c[7] - c[3], fx), fy);
}
#pragma GCC diagnostic pop

/** \brief Trilinear blend of eight corner values c[i], corner i = (i&1, (i>>1)&1, (i>>2)&1). */
inline float
trilinear (const std::array<float, 8>& c, const Eigen::Vector3f& f)
{
  return trilinearBlend (c.data (), f.x (), f.y (), f.z ());
}

/** \brief Position of the zero crossing between two samples along an edge, as a fraction
  * of the edge from the first sample (values of opposite sign).
  */
inline float
zeroCrossing (float a, float b)
{
  const float d = a - b;
  return std::abs (d) > 1e-12f ? std::clamp (a / d, 0.f, 1.f) : 0.5f;
}
}  // namespace reconstruction
}  // namespace cuefusion
