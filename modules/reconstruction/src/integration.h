// SPDX-License-Identifier: BSD-3-Clause
#pragma once

#include <cuefusion/common/pinhole_camera.h>
#include <cuefusion/reconstruction/voxel.h>

#include <Eigen/Core>

#include <cstddef>
#include <cstdint>
#include <vector>

namespace cuefusion
{
namespace reconstruction
{
namespace detail
{
/** \brief What integrating one frame into a block needs: the depth (and colour) image as
  * raw rows, the intrinsics and the world-to-camera motion, and the volume's constants.
  */
struct IntegrationFrame
{
  const float* depth = nullptr;
  std::size_t depth_step = 0;  ///< floats per depth row
  const std::uint8_t* color = nullptr;  ///< BGR rows, or nullptr
  std::size_t color_step = 0;           ///< bytes per colour row
  FloatIntrinsics camera;
  Eigen::Matrix3f R_cw = Eigen::Matrix3f::Identity ();
  Eigen::Vector3f t_cw = Eigen::Vector3f::Zero ();
  float voxel_size = 0.f, truncation = 0.f, min_depth = 0.f, max_depth = 0.f, max_weight = 1.f;
};

/** \brief A depth sample inside the fusion range [min, max] (NaN fails both comparisons). */
inline bool
usableDepth (float z, float min_depth, float max_depth)
{
  return z >= min_depth && z <= max_depth;
}

/** \brief §4.1.4 for every voxel of \a block: projected into the depth map, its truncated
  * distance (and colour) averaged in. Plain C++. When \a observed is given, the voxels
  * the frame saw inside the truncation band are appended to it (see SurfaceObservation;
  * \a first_voxel is the block's id × kBlockVoxels).
  */
void
integrateBlockScalar (VoxelBlock& block, const IntegrationFrame& frame, std::uint32_t first_voxel,
                      std::vector<SurfaceObservation>* observed);

/** \brief The same, eight voxels (one x-row of the block) at a time with AVX2 + FMA.
  * Only call when cpuHasAvx2Fma(). Agrees with the scalar version up to rounding of the
  * voxel positions (a voxel on a pixel border may fall to the other pixel).
  */
void
integrateBlockAvx2 (VoxelBlock& block, const IntegrationFrame& frame, std::uint32_t first_voxel,
                    std::vector<SurfaceObservation>* observed);
}  // namespace detail
}  // namespace reconstruction
}  // namespace cuefusion
