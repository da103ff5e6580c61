// SPDX-License-Identifier: BSD-3-Clause
#pragma once

#include <cuefusion/reconstruction/tsdf_volume.h>

#include <cstring>

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
      id_ = volume_.store ().findBlock (b);
      block_ = id_ >= 0 ? &volume_.store ().block (static_cast<std::size_t> (id_)) : nullptr;
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

  /** \brief As get (v), with the voxel's number in \a number (kNoVoxel when unallocated). */
  inline const TsdfVoxel*
  get (const Eigen::Vector3i& v, VoxelNumber& number)
  {
    std::size_t i;
    const VoxelBlock* blk = locate (v, i);
    number = blk != nullptr ? voxelNumber (static_cast<std::size_t> (id_), i) : kNoVoxel;
    return blk != nullptr ? &blk->voxels[i] : nullptr;
  }

  /** \brief Raw compact distances (sdf · kDistanceScale, as floats) of the cell with lower
    * corner \a v, corner i at offset (i&1, (i>>1)&1, (i>>2)&1); false when any is
    * unallocated or unobserved. All eight lie in the distance layer of \a v's block, apron
    * included (see VoxelBlock). Callers scale the blended result once instead of every
    * corner (a division per corner was a tenth of the ray caster's time).
    */
  __attribute__ ((always_inline)) inline bool
  cell (const Eigen::Vector3i& v, std::array<float, 8>& values)
  {
    const Eigen::Vector3i b = blockOfVoxel (v);
    const VoxelBlock* blk = block (b);
    if (blk == nullptr)
      return false;
    const Eigen::Vector3i l = v - b * kBlockSide;
    return cellInBlock (blk->distances.data () + distanceIndex (l.x (), l.y (), l.z ()), values.data ());
  }

  /** \brief The cell whose lower corner's distance is at \a base in a distance layer:
    * corner i goes to values[i]. The corners come in x-pairs, adjacent in the
    * layer: four 32-bit loads.
    */
  static inline bool
  cellInBlock (const std::int16_t* base, float* values)
  {
    constexpr int dy = kDistanceSide, dz = kDistanceSide * kDistanceSide;
    const std::int16_t* rows[4] = {base, base + dy, base + dz, base + dz + dy};
    bool observed = true;
    for (std::size_t p = 0; p < 4; ++p)
    {
      std::uint32_t pair;
      std::memcpy (&pair, rows[p], sizeof pair);
      const auto first = static_cast<std::int16_t> (pair & 0xffffu), second = static_cast<std::int16_t> (pair >> 16);
      static_assert (__BYTE_ORDER__ == __ORDER_LITTLE_ENDIAN__, "the pair's first distance is its low half");
      observed &= first != kUnobservedDistance && second != kUnobservedDistance;
      values[2 * p] = static_cast<float> (first);
      values[2 * p + 1] = static_cast<float> (second);
    }
    return observed;
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
    constexpr float scale = 1.f / kDistanceScale;
    float gx, gy, gz;
    trilinearGradient (v.data (), f.x (), f.y (), f.z (), gx, gy, gz);
    grad = Eigen::Vector3f (gx * scale, gy * scale, gz * scale);
    sdf = trilinearBlend (v.data (), f.x (), f.y (), f.z ()) * scale;
    return true;
  }

  const TSDFVolume& volume () const { return volume_; }

private:
  const TSDFVolume& volume_;
  Eigen::Vector3i block_index_ = Eigen::Vector3i::Zero ();
  const VoxelBlock* block_ = nullptr;
  std::int32_t id_ = -1;  ///< block_'s id
  bool valid_ = false;
};
}  // namespace detail
}  // namespace reconstruction
}  // namespace cuefusion
