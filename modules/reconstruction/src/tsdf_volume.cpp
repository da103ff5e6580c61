// SPDX-License-Identifier: BSD-3-Clause
#include "integration.h"
#include "voxel_access.h"

#include <cuefusion/common/avx2.h>
#include <cuefusion/common/cpu_features.h>
#include <cuefusion/common/exceptions.h>
#include <cuefusion/common/hash.h>
#include <cuefusion/common/parallel.h>
#include <cuefusion/reconstruction/tsdf_volume.h>

#include <algorithm>
#include <sstream>
#include <array>
#include <cmath>
#include <cstring>
#include <limits>
#include <mutex>


namespace cuefusion
{
namespace reconstruction
{
namespace
{
/** \brief Per-thread filter of recently seen block keys (direct-mapped): neighbouring
  * pixels touch the same few blocks, so this drops most repeats before the serial merge.
  */
class RecentKeys
{
public:
  RecentKeys () { slots_.fill (~std::uint64_t{0}); }

  bool
  seen (std::uint64_t key)
  {
    std::uint64_t& slot = slots_[(key * 0x9E3779B97F4A7C15ull) >> 52];
    if (slot == key)
      return true;
    slot = key;
    return false;
  }

private:
  std::array<std::uint64_t, 4096> slots_;
};

}  // namespace

void
TSDFVolumeConfig::validate () const
{
  if (!(voxel_size > 0.0005 && voxel_size <= 1.0))
    throw ParameterError ("TSDFVolumeConfig::voxel_size", "must lie in (0.0005, 1] metres");
  if (!(truncation_voxels >= 1.0 && truncation_voxels <= kMaxTruncationVoxels))
    throw ParameterError ("TSDFVolumeConfig::truncation_voxels", "must lie in [1, 64] voxels");
  if (!(max_weight >= 1.f && max_weight <= 1e6f))
    throw ParameterError ("TSDFVolumeConfig::max_weight", "must lie in [1, 1e6]");
  if (!(min_depth >= 0.0 && max_depth > min_depth && std::isfinite (max_depth)))
    throw ParameterError ("TSDFVolumeConfig::max_depth", "depth range must satisfy 0 <= min < max < inf");
  if (bounds && (bounds->isEmpty () || !bounds->min ().allFinite () || !bounds->max ().allFinite ()))
    throw ParameterError ("TSDFVolumeConfig::bounds", "must be a finite, non-empty box");
}

cv::Mat
RaycastResult::depth () const
{
  cv::Mat out (vertices.size (), CV_32F);
  for (int y = 0; y < vertices.rows; ++y)
  {
    const cv::Vec3f* v = vertices.ptr<cv::Vec3f> (y);
    float* d = out.ptr<float> (y);
    for (int x = 0; x < vertices.cols; ++x)
      d[x] = std::isnan (v[x][0]) ? 0.f : v[x][2];
  }
  return out;
}

TSDFVolume::TSDFVolume (const TSDFVolumeConfig& config) : config_ (config)
{
  config_.validate ();
}

void
TSDFVolume::reset ()
{
  store_.clear ();
  integrated_blocks_.clear ();
  observed_.clear ();
  integrated_size_ = cv::Size ();
  block_stamp_.clear ();
  stamp_ = 0;
}

double
TSDFVolume::addressableReach () const
{
  // voxel_block_hash.h's limit, less the farthest a frame's blocks reach from its camera.
  return std::max (0.0, kVoxelCoordinateLimit * config_.voxel_size - config_.max_depth - config_.truncation ());
}

bool
TSDFVolume::reaches (const Eigen::Isometry3d& pose) const
{
  return pose.matrix ().allFinite () && pose.translation ().cwiseAbs ().maxCoeff () <= addressableReach ();
}

std::uint64_t
TSDFVolume::fingerprint () const
{
  // Each block's coordinates mixed (splitMix64), summed: independent of the allocation order.
  std::uint64_t sum = 0;
  for (std::size_t id = 0; id < store_.size (); ++id)
    sum += splitMix64 (packBlockIndex (store_.block (id).index));
  std::uint64_t voxel_bits = 0, truncation_bits = 0;
  std::memcpy (&voxel_bits, &config_.voxel_size, sizeof voxel_bits);
  std::memcpy (&truncation_bits, &config_.truncation_voxels, sizeof truncation_bits);
  return splitMix64 (sum ^ splitMix64 (voxel_bits) ^ splitMix64 (truncation_bits + 1) ^ store_.size ());
}

std::size_t
TSDFVolume::memoryUsage () const
{
  return store_.memoryUsage () + store_.size () * sizeof (std::uint32_t);  // block_stamp_
}

void
TSDFVolume::allocateBlocks (const cv::Mat& depth, const PinholeCamera& camera, const Eigen::Isometry3d& pose)
{
  const float truncation = static_cast<float> (config_.truncation ());
  const float inv_block = static_cast<float> (1.0 / config_.blockSize ());
  const float min_depth = static_cast<float> (config_.min_depth), max_depth = static_cast<float> (config_.max_depth);
  const Eigen::Matrix3f R = pose.linear ().cast<float> ();
  const Eigen::Vector3f origin_blocks = pose.translation ().cast<float> () * inv_block;
  const float inv_fx = static_cast<float> (1.0 / camera.fx), inv_fy = static_cast<float> (1.0 / camera.fy);
  const float cx = static_cast<float> (camera.cx), cy = static_cast<float> (camera.cy);
  // Samples along each ray through the band [d − τ, d + τ], at most half a block apart,
  // and every second pixel: at 5 m a pixel of a 525 px focal length spans 1 cm, far
  // below the 8 cm of a block.
  const int samples = 1 + static_cast<int> (std::ceil (2.f * truncation * inv_block * 2.f));
  const float step = 2.f * truncation / static_cast<float> (samples - 1);
  constexpr int kPixelStride = 2;

  // Rows in fixed chunks; each chunk's candidates are kept apart and read back in chunk
  // order, so blocks are allocated in the same order on every run.
  const int rows = (depth.rows + kPixelStride - 1) / kPixelStride;
  constexpr int kRowsPerChunk = 8;
  std::vector<std::vector<std::uint64_t>> candidates (static_cast<std::size_t> (chunkCount (rows, kRowsPerChunk)));
  parallelForChunks (rows, kRowsPerChunk, [&] (int k, int begin, int end) {
    std::vector<std::uint64_t>& mine = candidates[static_cast<std::size_t> (k)];
    RecentKeys recent;
    for (int r = begin; r < end; ++r)
    {
      const int v = r * kPixelStride;
      const float* row = depth.ptr<float> (v);
      // The row's ray at u = 0 and its step per pixel, in block units per metre of depth
      // (PinholeCamera::backProject divides in double, twice per pixel).
      const Eigen::Vector3f ray0 = R * Eigen::Vector3f (-cx * inv_fx, (static_cast<float> (v) - cy) * inv_fy, 1.f) * inv_block;
      const Eigen::Vector3f ray_step = R.col (0) * (inv_fx * inv_block);
      for (int u = 0; u < depth.cols; u += kPixelStride)
      {
        const float d = row[u];
        if (!detail::usableDepth (d, min_depth, max_depth))
          continue;
        const Eigen::Vector3f ray = ray0 + ray_step * static_cast<float> (u);
        for (int s = 0; s < samples; ++s)
        {
          const float z = d - truncation + step * static_cast<float> (s);
          if (z <= 0.f)
            continue;
          const Eigen::Vector3f b = origin_blocks + ray * z;
          const Eigen::Vector3i index = fastFloor (b);
          if (!inBlockRange (index))
            continue;
          const std::uint64_t key = packBlockIndex (index);
          if (!recent.seen (key))
            mine.push_back (key);
        }
      }
    }
  });

  ++stamp_;
  integrated_blocks_.clear ();
  block_stamp_.resize (store_.size (), 0);  // a loaded volume's blocks have none yet
  const double block_size = config_.blockSize ();
  for (const auto& keys : candidates)
    for (const std::uint64_t key : keys)
    {
      std::int32_t id = store_.find (key);
      if (id == VoxelBlockHash::kNone)
      {
        const Eigen::Vector3i index = unpackBlockIndex (key);
        if (config_.bounds)
        {
          const Eigen::AlignedBox3d box (index.cast<double> () * block_size, (index.cast<double> ().array () + 1.0).matrix () * block_size);
          if (!config_.bounds->intersects (box))
            continue;
        }
        id = store_.allocate (index).first;
        block_stamp_.resize (store_.size (), 0);
      }
      if (block_stamp_[static_cast<std::size_t> (id)] != stamp_)
      {
        block_stamp_[static_cast<std::size_t> (id)] = stamp_;
        integrated_blocks_.push_back (id);
      }
    }
}

void
TSDFVolume::integrate (const cv::Mat& depth, const cv::Mat& color, const PinholeCamera& camera,
                       const Eigen::Isometry3d& pose)
{
  if (depth.type () != CV_32F || depth.empty ())
    throw Error ("TSDFVolume::integrate", "depth must be a non-empty CV_32F image");
  if (depth.cols != camera.width || depth.rows != camera.height)
    throw Error ("TSDFVolume::integrate", "depth size differs from the camera's image size");
  if (!color.empty () && (color.type () != CV_8UC3 || color.size () != depth.size ()))
    throw Error ("TSDFVolume::integrate", "colour must be CV_8UC3 of the depth's size (or empty)");
  if (!pose.matrix ().allFinite ())
    throw Error ("TSDFVolume::integrate", "pose is not finite");
  if (!reaches (pose))
  {
    std::ostringstream msg;
    msg << "the camera at (" << pose.translation ().x () << ", " << pose.translation ().y () << ", " << pose.translation ().z ()
        << ") m is outside the volume's addressable range (±" << addressableReach () << " m from the origin at "
        << config_.voxel_size << " m voxels)";
    throw Error ("TSDFVolume::integrate", msg.str ());
  }

  allocateBlocks (depth, camera, pose);

  const Eigen::Isometry3f world_to_camera = pose.inverse ().cast<float> ();
  detail::IntegrationFrame frame;
  frame.depth = depth.ptr<float> ();
  frame.depth_step = depth.step1 ();
  if (!color.empty ())
  {
    frame.color = color.ptr<std::uint8_t> ();
    frame.color_step = color.step[0];
  }
  frame.camera = FloatIntrinsics (camera);
  frame.R_cw = world_to_camera.linear ();
  frame.t_cw = world_to_camera.translation ();
  frame.voxel_size = static_cast<float> (config_.voxel_size);
  frame.truncation = static_cast<float> (config_.truncation ());
  frame.min_depth = static_cast<float> (config_.min_depth);
  frame.max_depth = static_cast<float> (config_.max_depth);
  frame.max_weight = config_.max_weight;
  const auto kernel = vectorKernelsEnabled () ? &detail::integrateBlockAvx2 : &detail::integrateBlockScalar;
  const int n = static_cast<int> (integrated_blocks_.size ());
  constexpr int kChunk = 16;
  // One observation list per work item, so no two threads append to one; the lists (and
  // their capacity) are reused frame after frame.
  integrated_size_ = depth.size ();
  if (record_observed_)
  {
    observed_.resize (static_cast<std::size_t> (chunkCount (n, kChunk)));
    for (auto& list : observed_)
      list.clear ();
  }
  else
    observed_.clear ();
  parallelForChunks (n, kChunk, [&] (int chunk, int begin, int end) {
    std::vector<SurfaceObservation>* observed = record_observed_ ? &observed_[static_cast<std::size_t> (chunk)] : nullptr;
    for (int i = begin; i < end; ++i)
    {
      const auto id = static_cast<std::uint32_t> (integrated_blocks_[static_cast<std::size_t> (i)]);
      kernel (store_.block (id), frame, id * static_cast<std::uint32_t> (kBlockVoxels), observed);
      // Safe in parallel: each apron entry has one source block, and the kernel writes
      // only a block's own voxels' distances, never its apron.
      store_.copyToLowerAprons (id);
    }
  });
}

}  // namespace reconstruction
}  // namespace cuefusion
