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
/** \brief One voxel of the TSDF volume (16 bytes).
  *
  * sdf is the truncated signed distance in units of the truncation distance, in [-1, 1]
  * (positive in front of the surface). weight is the fusion weight of §4.1.4, capped at
  * w_max. The label layer (label, label_confidence Ψ of §4.2.4) takes 5 of the 16 bytes:
  * a 32-bit segment label so labels never wrap on long sequences, and Ψ ≤ Ψ_max = 10
  * fits a byte.
  */
struct TsdfVoxel
{
  float sdf = 1.f;
  float weight = 0.f;
  std::uint8_t r = 0, g = 0, b = 0;
  std::uint8_t label_confidence = 0;
  std::uint32_t label = 0;
};
static_assert (sizeof (TsdfVoxel) == 16, "TsdfVoxel is meant to stay 16 bytes");

/** \brief Voxels per block side; a block is 8³ voxels as in InfiniTAM. */
constexpr int kBlockSide = 8;
constexpr int kBlockVoxels = kBlockSide * kBlockSide * kBlockSide;

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

/** \brief 8³ voxels and a compact copy of their distances.
  *
  * The ray caster reads only distances, and reading them from the 16-byte voxels costs a
  * cell of 2×2×2 voxels four cache lines; the 2-byte copy mostly fits one, and a whole
  * block's distances are 1 KiB instead of 8. integrate() keeps both in step (and load()
  * rebuilds the copy); code that writes sdf or weight directly must call
  * refreshDistances().
  */
struct VoxelBlock
{
  Eigen::Vector3i index = Eigen::Vector3i::Zero ();  ///< block coordinates (voxel index / 8)
  std::array<TsdfVoxel, kBlockVoxels> voxels;
  std::array<std::int16_t, kBlockVoxels> distances;

  VoxelBlock () { distances.fill (kUnobservedDistance); }

  void
  refreshDistances ()
  {
    for (std::size_t i = 0; i < voxels.size (); ++i)
      distances[i] = encodeDistance (voxels[i]);
  }
};

/** \brief A voxel that the last integrated frame saw inside the truncation band of the
  * surface (TSDFVolume::setRecordObservedSurface): updated by that frame, |z − D(u)| < τ at
  * the nearest pixel and |sdf| < 1 after the update. The label update of §4.2.4 walks
  * these instead of projecting every voxel of the frame's blocks a second time.
  */
struct SurfaceObservation
{
  std::uint32_t voxel = 0;  ///< block id × kBlockVoxels + the voxel's index in its block
  std::uint32_t pixel = 0;  ///< nearest pixel the voxel projects to: v << 16 | u
  float gap = 0.f;          ///< |z_voxel − D(u)| at that pixel, metres (< truncation)
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

/** \brief Linear index of local voxel (x, y, z) inside its block. */
inline int
localVoxelIndex (int x, int y, int z)
{
  return x + kBlockSide * (y + kBlockSide * z);
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

/** \brief Trilinear blend of eight corner values c[i], corner i = (i&1, (i>>1)&1, (i>>2)&1). */
inline float
trilinear (const std::array<float, 8>& c, const Eigen::Vector3f& f)
{
  const float x0 = c[0] + (c[1] - c[0]) * f.x ();
  const float x1 = c[2] + (c[3] - c[2]) * f.x ();
  const float x2 = c[4] + (c[5] - c[4]) * f.x ();
  const float x3 = c[6] + (c[7] - c[6]) * f.x ();
  const float y0 = x0 + (x1 - x0) * f.y ();
  const float y1 = x2 + (x3 - x2) * f.y ();
  return y0 + (y1 - y0) * f.z ();
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
