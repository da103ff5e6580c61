// SPDX-License-Identifier: BSD-3-Clause
// §4.2.4: each voxel's label and confidence Ψ from the frame segments L^p (the map
// update after propagation, §4.2.2, in segment_propagation.cpp).
#include <cuefusion/common/exceptions.h>
#include <cuefusion/reconstruction/tsdf_volume.h>
#include <cuefusion/segmentation/parallel.h>
#include <cuefusion/segmentation/voxel_label_update.h>

#include <atomic>
#include <cmath>

namespace cuefusion
{
namespace segmentation
{
void
VoxelLabelUpdateConfig::validate () const
{
  if (max_confidence < 1 || max_confidence > 255)
    throw ParameterError ("VoxelLabelUpdateConfig::max_confidence", "must lie in [1, 255]");
  if (!(band > 0.f && band <= 1.f))
    throw ParameterError ("VoxelLabelUpdateConfig::band", "must lie in (0, 1] truncation units");
}

namespace
{
/** \brief §4.2.4 for one voxel and the label its pixel observed; true when it wrote. */
inline bool
updateVoxelLabel (std::uint32_t& voxel_label, std::uint8_t& confidence, std::uint32_t label, const GlobalSegmentMap& map,
                  std::uint8_t max_confidence)
{
  if (voxel_label == 0)
  {
    voxel_label = label;
    confidence = 0;
    return true;
  }
  if (map.resolve (voxel_label) == map.resolve (label))
  {
    if (confidence >= max_confidence)
      return false;
    ++confidence;
    return true;
  }
  if (confidence > 0)
    --confidence;
  if (confidence == 0)
    voxel_label = label;
  return true;
}
}  // namespace

std::size_t
updateVoxelLabels (const reconstruction::TSDFVolume& volume, VoxelLabelLayer& layer, const cv::Mat& labels,
                   const GlobalSegmentMap& map, const VoxelLabelUpdateConfig& config)
{
  config.validate ();
  if (!volume.getRecordObservedSurface ())
    throw Error ("updateVoxelLabels", "the volume does not record the voxels it integrates: call "
                                      "setRecordObservedSurface (true) before integrate()");
  if (labels.type () != CV_32S || labels.size () != volume.lastIntegratedSize ())
    throw Error ("updateVoxelLabels", "L^p must be CV_32S of the size of the frame last integrated");
  // The voxels come from integrate(): it projects each voxel of the frame's blocks anyway
  // and lists those inside the truncation band of the surface their pixel sees. Visiting
  // every voxel of those blocks again here (a second projection and depth lookup per
  // voxel, mostly of voxels outside the band) was 3 ms a frame on 7scenes-redkitchen.
  const float max_gap = config.band * static_cast<float> (volume.getConfig ().truncation ());
  const float band = config.band;
  const auto max_confidence = static_cast<std::uint8_t> (config.max_confidence);
  const std::vector<std::vector<reconstruction::SurfaceObservation>>& lists = volume.lastObservedSurface ();
  layer.resize (volume.blockCount ());  // before the parallel loop: blocks are not made while it runs
  std::atomic<std::size_t> writes (0);
  constexpr std::size_t kPrefetchAhead = 16;
  parallelForChunks (static_cast<int> (lists.size ()), 8, [&] (int, int begin, int end) {
    std::size_t local_writes = 0;
    for (int k = begin; k < end; ++k)
    {
      const std::vector<reconstruction::SurfaceObservation>& list = lists[static_cast<std::size_t> (k)];
      for (std::size_t j = 0; j < list.size (); ++j)
      {
        const reconstruction::SurfaceObservation& seen = list[j];
        if (j + kPrefetchAhead < list.size ())
        {
          const reconstruction::VoxelNumber ahead = list[j + kPrefetchAhead].voxel;
          VoxelLabelLayer::Block& block = layer.block (ahead / reconstruction::kBlockVoxels);
          __builtin_prefetch (&block.labels[ahead % reconstruction::kBlockVoxels], 1);
          __builtin_prefetch (&block.confidence[ahead % reconstruction::kBlockVoxels], 1);
        }
        const std::int32_t observed = labels.ptr<std::int32_t> (static_cast<int> (seen.pixel >> 16))[seen.pixel & 0xffffu];
        if (observed <= 0 || !(seen.gap < max_gap))
          continue;
        // The fused distance comes with the observation: the TSDF itself is not read.
        const std::size_t block = seen.voxel / reconstruction::kBlockVoxels, local = seen.voxel % reconstruction::kBlockVoxels;
        if (std::abs (seen.sdf) < band)
        {
          VoxelLabelLayer::Block& labels_of_block = layer.block (block);
          local_writes += updateVoxelLabel (labels_of_block.labels[local], labels_of_block.confidence[local],
                                            static_cast<std::uint32_t> (observed), map, max_confidence);
        }
      }
    }
    writes += local_writes;
  });
  return writes.load ();
}

cv::Mat
resolveLabels (const cv::Mat& labels, const GlobalSegmentMap& map)
{
  CV_Assert (labels.type () == CV_32S);
  cv::Mat out (labels.size (), CV_32S);
  for (int y = 0; y < labels.rows; ++y)
    for (int x = 0; x < labels.cols; ++x)
    {
      const std::int32_t l = labels.at<std::int32_t> (y, x);
      out.at<std::int32_t> (y, x) = l > 0 ? static_cast<std::int32_t> (map.resolve (static_cast<std::uint32_t> (l))) : 0;
    }
  return out;
}
}  // namespace segmentation
}  // namespace cuefusion
