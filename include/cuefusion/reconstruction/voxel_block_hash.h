// SPDX-License-Identifier: BSD-3-Clause
#pragma once

#include <cuefusion/reconstruction/voxel.h>

#include <Eigen/Core>

#include <cstddef>
#include <cstdint>
#include <vector>

namespace cuefusion
{
namespace reconstruction
{
/** \brief The volume's addressable range, one constant for the block hash, the surface
  * extraction and the volume loader: every voxel coordinate (a block's apron included)
  * lies in [-2^19, 2^19), the 20 bits per axis that the surface extraction packs into an
  * edge key. At 1 cm voxels that is ±5.2 km from the origin. Blocks outside are never
  * allocated, a volume file naming one is refused, and TSDFVolume::integrate refuses a
  * camera whose depth range reaches outside.
  */
constexpr int kVoxelCoordinateBits = 20;
constexpr std::int32_t kVoxelCoordinateLimit = 1 << (kVoxelCoordinateBits - 1);
constexpr std::int32_t kMinBlockCoordinate = -kVoxelCoordinateLimit / kBlockSide;
constexpr std::int32_t kMaxBlockCoordinate = (kVoxelCoordinateLimit - kBlockSide - 1) / kBlockSide;

/** \brief Block coordinates packed into one 64-bit key, 21 bits per axis: more than the
  * addressable range needs, so every block inBlockRange() accepts has its own key.
  */
constexpr int kBlockKeyBits = 21;
constexpr std::int32_t kBlockKeyOffset = 1 << (kBlockKeyBits - 1);
static_assert (kMaxBlockCoordinate < kBlockKeyOffset && -kMinBlockCoordinate <= kBlockKeyOffset, "block keys must cover the range");

inline bool
inBlockRange (const Eigen::Vector3i& b)
{
  return (b.array () >= kMinBlockCoordinate).all () && (b.array () <= kMaxBlockCoordinate).all ();
}

inline std::uint64_t
packBlockIndex (const Eigen::Vector3i& b)
{
  constexpr std::uint64_t mask = (std::uint64_t{1} << kBlockKeyBits) - 1;
  return (static_cast<std::uint64_t> (b.x () + kBlockKeyOffset) & mask) |
         ((static_cast<std::uint64_t> (b.y () + kBlockKeyOffset) & mask) << kBlockKeyBits) |
         ((static_cast<std::uint64_t> (b.z () + kBlockKeyOffset) & mask) << (2 * kBlockKeyBits));
}

inline Eigen::Vector3i
unpackBlockIndex (std::uint64_t key)
{
  constexpr std::uint64_t mask = (std::uint64_t{1} << kBlockKeyBits) - 1;
  return {static_cast<int> (key & mask) - kBlockKeyOffset,
          static_cast<int> ((key >> kBlockKeyBits) & mask) - kBlockKeyOffset,
          static_cast<int> ((key >> (2 * kBlockKeyBits)) & mask) - kBlockKeyOffset};
}

/** \brief Open-addressing hash table (linear probing) from packed block keys to block ids.
  *
  * Written here rather than using std::unordered_map because ray casting looks blocks up
  * millions of times per frame: a flat table of keys probed from a multiplicative hash
  * keeps a lookup to one or two cache lines, where unordered_map chases a node pointer.
  * Lookups are safe from many threads as long as nobody inserts meanwhile.
  */
class VoxelBlockHash
{
public:
  static constexpr std::int32_t kNone = -1;

  VoxelBlockHash () { clear (); }

  /** \brief Block id stored for \a key, or kNone. */
  inline std::int32_t
  find (std::uint64_t key) const
  {
    for (std::size_t slot = hash (key) & mask_;; slot = (slot + 1) & mask_)
    {
      const std::uint64_t k = keys_[slot];
      if (k == key)
        return values_[slot];
      if (k == kEmptyKey)
        return kNone;
    }
  }

  /** \brief Stores \a value under \a key unless the key is present; returns the stored id
    * and whether it was inserted now.
    */
  std::pair<std::int32_t, bool>
  insert (std::uint64_t key, std::int32_t value);

  void
  clear (std::size_t capacity = 1024);

  std::size_t size () const { return size_; }

  std::size_t memoryBytes () const { return keys_.size () * (sizeof (std::uint64_t) + sizeof (std::int32_t)); }

private:
  static constexpr std::uint64_t kEmptyKey = ~std::uint64_t{0};

  static inline std::size_t
  hash (std::uint64_t key)
  {
    key ^= key >> 31;
    key *= 0x9E3779B97F4A7C15ull;
    return static_cast<std::size_t> (key ^ (key >> 29));
  }

  void
  rehash (std::size_t capacity);

  std::vector<std::uint64_t> keys_;
  std::vector<std::int32_t> values_;
  std::size_t size_ = 0;
  std::size_t mask_ = 0;
};
}  // namespace reconstruction
}  // namespace cuefusion
