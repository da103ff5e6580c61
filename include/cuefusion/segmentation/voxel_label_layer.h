// SPDX-License-Identifier: BSD-3-Clause
#pragma once

#include <cuefusion/reconstruction/tsdf_volume.h>
#include <cuefusion/reconstruction/voxel.h>

#include <opencv2/core.hpp>

#include <array>
#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <vector>

namespace cuefusion
{
namespace segmentation
{
/** \brief The per-voxel segment labels of §4.2.4 and their confidence Ψ: a layer of its own
  * beside the TSDF volume, keyed like it (one block per block id of the volume, one slot
  * per voxel: reconstruction::VoxelNumber), and owned by the segmentation side, as voxblox
  * keeps its label layer beside its TSDF layer. The volume knows nothing of it: the
  * segmentation reads the volume (which voxels a frame saw, their distances) and writes
  * here.
  *
  * Label 0 is "unlabelled". A block of the volume the layer has not grown to (resize ())
  * reads as unlabelled.
  */
class VoxelLabelLayer
{
public:
  /** \brief The labels and Ψ of one 8³ block, in the volume's voxel order (localVoxelIndex). */
  struct Block
  {
    std::array<std::uint32_t, reconstruction::kBlockVoxels> labels{};
    std::array<std::uint8_t, reconstruction::kBlockVoxels> confidence{};
  };

  /** \brief Grows the layer to \a blocks blocks (the volume's blockCount ()), the new ones
    * unlabelled; never shrinks (reset () empties it).
    */
  void
  resize (std::size_t blocks);

  /** \brief Drops every block (with TSDFVolume::reset ()). */
  void
  reset ()
  {
    blocks_.clear ();
    label_values_.blocks.clear ();
  }

  /** \brief The labels as a layer the volume's raycast samples
    * (DenseReconstruction::setModelValues): L^m comes out of the raycast itself. Its
    * address stays while the layer lives; its content follows resize () and reset ().
    */
  const reconstruction::VoxelValueLayer& labelValues () const { return label_values_; }

  std::size_t blockCount () const { return blocks_.size (); }

  /** \brief Bytes held by the blocks. */
  std::size_t
  memoryUsage () const
  {
    return blocks_.size () * (sizeof (Block) + sizeof (std::unique_ptr<Block>));
  }

  /** \brief The label of voxel \a v; 0 for kNoVoxel or a block beyond the layer. */
  std::uint32_t
  label (reconstruction::VoxelNumber v) const
  {
    const std::size_t id = v / reconstruction::kBlockVoxels;
    return v != reconstruction::kNoVoxel && id < blocks_.size () ? blocks_[id]->labels[v % reconstruction::kBlockVoxels] : 0u;
  }

  /** \brief Ψ of voxel \a v; 0 for kNoVoxel or a block beyond the layer. */
  std::uint8_t
  confidence (reconstruction::VoxelNumber v) const
  {
    const std::size_t id = v / reconstruction::kBlockVoxels;
    return v != reconstruction::kNoVoxel && id < blocks_.size () ? blocks_[id]->confidence[v % reconstruction::kBlockVoxels] : 0u;
  }

  /** \brief Block \a id, which must be below blockCount (). */
  Block& block (std::size_t id) { return *blocks_[id]; }
  const Block& block (std::size_t id) const { return *blocks_[id]; }

  /** \brief L^m (§4.2.2.1): the label of the voxel each pixel of \a voxels
    * (RaycastResult::voxels, CV_32S) shows, 0 where none; \a labels is CV_32S of its size.
    */
  void
  labelImage (const cv::Mat& voxels, cv::Mat& labels) const;

  /** \brief Writes the labelled blocks in a versioned binary format, each by its block
    * coordinates in \a volume (so that load () finds them again), each label as
    * \a label_map (label) when given (0 stays 0); atomic (temporary file, then rename).
    * Throws cuefusion::Error naming the file.
    */
  void
  save (const std::string& path, const reconstruction::TSDFVolume& volume,
        const std::function<std::uint32_t (std::uint32_t)>& label_map = {}) const;

  /** \brief Reads a file written by save () for \a volume (TSDFVolume::load of the volume
    * saved with it); throws cuefusion::Error naming the file when it is missing, of another
    * format or version, truncated, or lists a block \a volume does not have or one twice.
    */
  static VoxelLabelLayer
  load (const std::string& path, const reconstruction::TSDFVolume& volume);

  VoxelLabelLayer () = default;
  VoxelLabelLayer (VoxelLabelLayer&&) = default;
  /** Keeps this layer's labelValues () address (the raycast may hold it); takes the content. */
  VoxelLabelLayer& operator= (VoxelLabelLayer&& other) = default;

private:
  std::vector<std::unique_ptr<Block>> blocks_;
  reconstruction::VoxelValueLayer label_values_;  ///< blocks_[id]->labels.data (), per block
};
}  // namespace segmentation
}  // namespace cuefusion
