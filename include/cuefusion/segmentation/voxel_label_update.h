// SPDX-License-Identifier: BSD-3-Clause
#pragma once

#include <cuefusion/segmentation/global_segment_map.h>

#include <opencv2/core.hpp>

#include <cstddef>

namespace cuefusion
{
namespace reconstruction
{
class TSDFVolume;
}

namespace segmentation
{
class VoxelLabelLayer;

/** \brief Parameters of the per-voxel label update (§4.2.4). */
struct VoxelLabelUpdateConfig
{
  int max_confidence = 10;    ///< Ψ_max
  float band = 1.f;           ///< voxels within band × truncation of the surface (by sdf and along the pixel's ray) are updated: the whole band, as §4.2.4 says (measured: 0.25 lost 20–30 % IoU)
  void validate () const;
};
/// The name before 0.2 (one config per class, named after it).
using SegmentUpdateConfig [[deprecated ("renamed VoxelLabelUpdateConfig")]] = VoxelLabelUpdateConfig;

/** \brief §4.2.4: every voxel the frame last integrated into \a volume saw inside the
  * truncation band of the surface its pixel shows (|z_voxel − D(u)| < band · τ along that
  * pixel's ray, and |sdf| < band — voxels of surfaces hidden behind it are not touched),
  * where that pixel of L^p carries a label, is updated in \a layer: unlabelled → the pixel's label
  * with Ψ = 0; the same label (resolved) → Ψ = min(Ψ + 1, Ψ_max); a different one →
  * Ψ = max(Ψ − 1, 0), and at 0 the label is replaced. Each voxel is visited once, through
  * the pixel integration projected it to (projective association), so no two pixels race
  * for a voxel. \a labels is L^p of that frame (CV_32S, its size); the volume must record
  * what it integrates (TSDFVolume::setRecordObservedSurface). Returns the number of
  * voxel writes (label or Ψ changed).
  */
std::size_t
updateVoxelLabels (const reconstruction::TSDFVolume& volume, VoxelLabelLayer& layer, const cv::Mat& labels,
                   const GlobalSegmentMap& map, const VoxelLabelUpdateConfig& config = VoxelLabelUpdateConfig ());

/** \brief A raycast label map (voxel labels) resolved through the map's equivalence. */
cv::Mat
resolveLabels (const cv::Mat& labels, const GlobalSegmentMap& map);
}  // namespace segmentation
}  // namespace cuefusion
