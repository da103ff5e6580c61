#pragma once

#include <cuefusion/reconstruction/tsdf_volume.h>

namespace cuefusion
{
namespace reconstruction
{
namespace detail
{
/** \brief Reads voxels by global index, remembering the last block it looked up: loops
  * that walk through space (rays, marching cubes) mostly stay inside one block, so most
  * reads skip the hash. One accessor per thread.
  */
class VoxelAccessor
{
public:
  explicit VoxelAccessor (const TSDFVolume& volume) : volume_ (volume) {}

  /** \brief Block with block coordinates \a b, or nullptr when it is not allocated. */
  inline const VoxelBlock*
  block (const Eigen::Vector3i& b)
  {
    if (!valid_ || b != block_index_)
    {
      block_index_ = b;
      valid_ = true;
      const std::int32_t id = volume_.findBlock (b);
      block_ = id >= 0 ? volume_.blocks ()[static_cast<std::size_t> (id)].get () : nullptr;
    }
    return block_;
  }

  /** \brief Block holding voxel \a v (nullptr when unallocated) and \a v's index in it. */
  inline const VoxelBlock*
  locate (const Eigen::Vector3i& v, std::size_t& local)
  {
    const Eigen::Vector3i b = blockOfVoxel (v);
    const VoxelBlock* blk = block (b);
    const Eigen::Vector3i l = v - b * kBlockSide;
    local = static_cast<std::size_t> (localVoxelIndex (l.x (), l.y (), l.z ()));
    return blk;
  }

  inline const TsdfVoxel*
  get (const Eigen::Vector3i& v)
  {
    std::size_t i;
    const VoxelBlock* blk = locate (v, i);
    return blk != nullptr ? &blk->voxels[i] : nullptr;
  }

  /** \brief The compact distance of voxel \a v, or nullptr when its block is unallocated. */
  inline const std::int16_t*
  distance (const Eigen::Vector3i& v)
  {
    std::size_t i;
    const VoxelBlock* blk = locate (v, i);
    return blk != nullptr ? &blk->distances[i] : nullptr;
  }

  /** \brief Raw compact distances (sdf · kDistanceScale, as floats) of the cell with lower
    * corner \a v, corner i at offset (i&1, (i>>1)&1, (i>>2)&1); false when any is
    * unallocated or unobserved. Callers scale the blended result once instead of every
    * corner (a division per corner was a tenth of the ray caster's time).
    */
  inline bool
  cell (const Eigen::Vector3i& v, std::array<float, 8>& values)
  {
    const Eigen::Vector3i l = v - blockOfVoxel (v) * kBlockSide;
    if (l.x () < kBlockSide - 1 && l.y () < kBlockSide - 1 && l.z () < kBlockSide - 1)
    {
      // The whole cell lies in one block: one lookup, then fixed strides.
      const std::int16_t* base = distance (v);
      if (base == nullptr)
        return false;
      constexpr int dy = kBlockSide, dz = kBlockSide * kBlockSide;
      const std::int16_t d[8] = {base[0], base[1], base[dy], base[dy + 1], base[dz], base[dz + 1], base[dz + dy], base[dz + dy + 1]};
      bool observed = true;
      for (int i = 0; i < 8; ++i)
      {
        observed &= d[i] != kUnobservedDistance;
        values[static_cast<std::size_t> (i)] = static_cast<float> (d[i]);
      }
      return observed;
    }
    for (int i = 0; i < 8; ++i)
    {
      const std::int16_t* d = distance (v + Eigen::Vector3i (i & 1, (i >> 1) & 1, (i >> 2) & 1));
      if (d == nullptr || *d == kUnobservedDistance)
        return false;
      values[static_cast<std::size_t> (i)] = static_cast<float> (*d);
    }
    return true;
  }

  /** \brief Trilinear distance (truncation units) at continuous voxel coordinates \a g. */
  __attribute__ ((always_inline)) inline bool
  interpolate (const Eigen::Vector3f& g, float& sdf)
  {
    const Eigen::Vector3i lower = fastFloor (g);
    std::array<float, 8> values;
    if (!cell (lower, values))
      return false;
    sdf = trilinear (values, g - lower.cast<float> ()) * (1.f / kDistanceScale);
    return true;
  }

  /** \brief Trilinear distance at \a g and its gradient within the cell (truncation units
    * per voxel); false when a corner is unobserved.
    */
  __attribute__ ((always_inline)) inline bool
  interpolate (const Eigen::Vector3f& g, float& sdf, Eigen::Vector3f& grad)
  {
    const Eigen::Vector3i lower = fastFloor (g);
    std::array<float, 8> v;
    if (!cell (lower, v))
      return false;
    const Eigen::Vector3f f = g - lower.cast<float> ();
    const auto lerp = [] (float a, float b, float t) { return a + (b - a) * t; };
    constexpr float scale = 1.f / kDistanceScale;
    grad.x () = lerp (lerp (v[1] - v[0], v[3] - v[2], f.y ()), lerp (v[5] - v[4], v[7] - v[6], f.y ()), f.z ()) * scale;
    grad.y () = lerp (lerp (v[2] - v[0], v[3] - v[1], f.x ()), lerp (v[6] - v[4], v[7] - v[5], f.x ()), f.z ()) * scale;
    grad.z () = lerp (lerp (v[4] - v[0], v[5] - v[1], f.x ()), lerp (v[6] - v[2], v[7] - v[3], f.x ()), f.y ()) * scale;
    sdf = trilinear (v, f) * scale;
    return true;
  }

private:
  const TSDFVolume& volume_;
  Eigen::Vector3i block_index_ = Eigen::Vector3i::Zero ();
  const VoxelBlock* block_ = nullptr;
  bool valid_ = false;
};
}  // namespace detail
}  // namespace reconstruction
}  // namespace cuefusion
