// SPDX-License-Identifier: BSD-3-Clause
#pragma once

#include <cuefusion/reconstruction/voxel.h>
#include <cuefusion/reconstruction/voxel_block_hash.h>

#include <Eigen/Core>

#include <array>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <utility>
#include <vector>

namespace cuefusion
{
namespace reconstruction
{
/** \brief The storage of a TSDFVolume, apart from its algorithms (voxblox's Layer of
  * blocks beside its integrators; InfiniTAM's scene beside its engines): the 8³-voxel
  * blocks by id (ids count up from 0 in allocation order and never change while the block
  * lives), the hash from block coordinates to ids, and per block the blocks whose aprons
  * mirror its first layers (VoxelBlock::distances), kept so that writers update the
  * aprons without hash lookups.
  *
  * It knows no algorithm: TSDFVolume integrates, ray casts, extracts and saves over it, and
  * hands it out read-only (TSDFVolume::store ()), so readers find blocks and voxels here
  * and other layers key what they keep per voxel by its voxel numbers (VoxelNumber: block
  * id × kBlockVoxels + localVoxelIndex). Lookups are safe from many threads while nobody
  * allocates.
  */
class VoxelBlockStore
{
public:
  /** \brief Number of allocated blocks (ids are 0 … size () − 1). */
  std::size_t size () const { return blocks_.size (); }

  const VoxelBlock& block (std::size_t id) const { return *blocks_[id]; }

  /** \brief Writable block \a id. Whoever changes its voxels must call refreshDistances
    * (\a id) before the next raycast or extraction, which read the distance copies.
    */
  VoxelBlock& block (std::size_t id) { return *blocks_[id]; }

  /** \brief Block coordinates by id, packed (for per-frame passes over every block). */
  const std::vector<Eigen::Vector3i>& blockIndices () const { return block_indices_; }

  /** \brief Id of the block with packed coordinates \a key (packBlockIndex), or
    * VoxelBlockHash::kNone.
    */
  std::int32_t find (std::uint64_t key) const { return hash_.find (key); }

  /** \brief Id of the block with block coordinates \a index, or VoxelBlockHash::kNone. */
  std::int32_t
  findBlock (const Eigen::Vector3i& index) const
  {
    return inBlockRange (index) ? hash_.find (packBlockIndex (index)) : VoxelBlockHash::kNone;
  }

  /** \brief Voxel with global index \a v, or nullptr when its block is not allocated. */
  const TsdfVoxel* findVoxel (const Eigen::Vector3i& v) const;

  /** \brief Number of the voxel with global index \a v, or kNoVoxel when its block is not
    * allocated.
    */
  VoxelNumber findVoxelNumber (const Eigen::Vector3i& v) const;

  /** \brief The id of the block at \a index, allocating it (unobserved voxels, its apron
    * taken from the blocks above it) when it is missing, and whether it was allocated now.
    * Throws cuefusion::Error past 2^23 − 1 blocks (VoxelNumber's range).
    */
  std::pair<std::int32_t, bool> allocate (const Eigen::Vector3i& index);

  /** \brief Rebuilds block \a id's distance copy from its voxels, and the copies of its
    * first layers in the aprons of the blocks below it.
    */
  void refreshDistances (std::size_t id);

  /** \brief Copies block \a id's first layers into the aprons of the blocks below it. Safe
    * for different ids in parallel: each apron entry has one source block.
    */
  void copyToLowerAprons (std::size_t id);

  /** \brief Room for \a blocks blocks without reallocating the tables. */
  void reserve (std::size_t blocks);

  /** \brief Drops every block and frees the tables. */
  void clear ();

  /** \brief Bytes held by blocks, the per-block tables and the hash. */
  std::size_t memoryUsage () const;

private:
  VoxelBlockHash hash_;
  std::vector<std::unique_ptr<VoxelBlock>> blocks_;
  std::vector<Eigen::Vector3i> block_indices_;  ///< blocks_[i]->index, packed
  /** \brief Per block, the blocks whose aprons mirror part of it: entry j is the block at
    * index − (j & 1, (j >> 1) & 1, (j >> 2) & 1), nullptr where none is allocated (entry 0
    * unused).
    */
  std::vector<std::array<VoxelBlock*, 8>> lower_neighbours_;
};
}  // namespace reconstruction
}  // namespace cuefusion
