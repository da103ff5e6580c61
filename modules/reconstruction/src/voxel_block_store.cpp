// SPDX-License-Identifier: BSD-3-Clause
#include <cuefusion/common/exceptions.h>
#include <cuefusion/reconstruction/voxel_block_store.h>

namespace cuefusion
{
namespace reconstruction
{
VoxelNumber
VoxelBlockStore::findVoxelNumber (const Eigen::Vector3i& v) const
{
  const Eigen::Vector3i b = blockOfVoxel (v);
  const std::int32_t id = findBlock (b);
  if (id < 0)
    return kNoVoxel;
  const Eigen::Vector3i l = v - b * kBlockSide;
  return voxelNumber (static_cast<std::size_t> (id), static_cast<std::size_t> (localVoxelIndex (l.x (), l.y (), l.z ())));
}

const TsdfVoxel*
VoxelBlockStore::findVoxel (const Eigen::Vector3i& v) const
{
  const VoxelNumber n = findVoxelNumber (v);
  return n == kNoVoxel ? nullptr : &blocks_[n / kBlockVoxels]->voxels[n % kBlockVoxels];
}

std::pair<std::int32_t, bool>
VoxelBlockStore::allocate (const Eigen::Vector3i& index)
{
  const auto id = static_cast<std::int32_t> (blocks_.size ());
  // VoxelNumber numbers voxels in 32 bits, the last one kept for kNoVoxel: 2^23 − 1 blocks
  // (48 GiB of voxels).
  constexpr std::size_t kMaxBlocks = (std::size_t (1) << 32) / kBlockVoxels - 1;
  if (blocks_.size () >= kMaxBlocks)
    throw Error ("TSDFVolume", "more than 2^23 - 1 voxel blocks: use a larger voxel size or spatial bounds");
  const auto inserted = hash_.insert (packBlockIndex (index), id);
  if (inserted.second)
  {
    blocks_.push_back (std::make_unique<VoxelBlock> ());
    blocks_.back ()->index = index;
    block_indices_.push_back (index);
    // Link the new block with its allocated neighbours both ways (14 lookups per new
    // block): it takes its apron from the blocks above it, and becomes the apron's source
    // for the blocks below it (whose aprons already hold "unobserved" there, as its
    // distances do).
    VoxelBlock& block = *blocks_.back ();
    std::array<VoxelBlock*, 8> lower{};
    for (int j = 1; j < 8; ++j)
    {
      const Eigen::Vector3i offset (j & 1, (j >> 1) & 1, (j >> 2) & 1);
      const std::int32_t above = findBlock (index + offset);
      if (above >= 0)
      {
        copyApron (*blocks_[static_cast<std::size_t> (above)], block, j);
        lower_neighbours_[static_cast<std::size_t> (above)][static_cast<std::size_t> (j)] = &block;
      }
      const std::int32_t below = findBlock (index - offset);
      if (below >= 0)
        lower[static_cast<std::size_t> (j)] = blocks_[static_cast<std::size_t> (below)].get ();
    }
    lower_neighbours_.push_back (lower);
  }
  return inserted;
}

void
VoxelBlockStore::copyToLowerAprons (std::size_t id)
{
  const std::array<VoxelBlock*, 8>& lower = lower_neighbours_[id];
  for (int j = 1; j < 8; ++j)
    if (lower[static_cast<std::size_t> (j)] != nullptr)
      copyApron (*blocks_[id], *lower[static_cast<std::size_t> (j)], j);
}

void
VoxelBlockStore::refreshDistances (std::size_t id)
{
  blocks_[id]->refreshDistances ();
  copyToLowerAprons (id);
}

void
VoxelBlockStore::reserve (std::size_t blocks)
{
  blocks_.reserve (blocks);
  block_indices_.reserve (blocks);
  lower_neighbours_.reserve (blocks);
}

void
VoxelBlockStore::clear ()
{
  hash_.clear ();
  blocks_.clear ();
  blocks_.shrink_to_fit ();
  block_indices_.clear ();
  block_indices_.shrink_to_fit ();
  lower_neighbours_.clear ();
  lower_neighbours_.shrink_to_fit ();
}

std::size_t
VoxelBlockStore::memoryUsage () const
{
  return blocks_.size () * (sizeof (VoxelBlock) + sizeof (std::unique_ptr<VoxelBlock>) + sizeof (Eigen::Vector3i) +
                            sizeof (std::array<VoxelBlock*, 8>)) +
         hash_.memoryBytes ();
}
}  // namespace reconstruction
}  // namespace cuefusion
