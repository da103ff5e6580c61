// SPDX-License-Identifier: BSD-3-Clause
// Binary volume files: a fixed little-endian header, then every block with its voxels.
#include <cuefusion/common/exceptions.h>
#include <cuefusion/io/file_io.h>
#include <cuefusion/reconstruction/tsdf_volume.h>

#include <boost/filesystem.hpp>

#include <cstring>
#include <fstream>

namespace cuefusion
{
namespace reconstruction
{
namespace
{
constexpr char kMagic[8] = {'C', 'F', 'T', 'S', 'D', 'F', '\r', '\n'};
// Version 1 (cuefusion 0.1) had 16-byte voxels with the segment label inside; version 2
// holds the TSDF alone (12-byte voxels), the labels have a file of their own
// (segmentation::VoxelLabelLayer::save).
constexpr std::uint32_t kVersion = 2;

#pragma pack(push, 1)
struct VolumeHeader
{
  char magic[8];
  std::uint32_t version;
  std::uint32_t voxel_bytes;      ///< sizeof (TsdfVoxel)
  std::uint32_t block_side;       ///< kBlockSide
  double voxel_size;
  double truncation_voxels;
  float max_weight;
  double min_depth, max_depth;
  std::uint8_t has_bounds;
  double bounds[6];
  std::uint64_t block_count;
};
#pragma pack(pop)

constexpr std::size_t kBlockRecordBytes = 3 * sizeof (std::int32_t) + sizeof (TsdfVoxel) * kBlockVoxels;

static_assert (sizeof (float) == 4 && sizeof (double) == 8, "volume files assume IEEE-754 floats");
}  // namespace

void
TSDFVolume::save (const std::string& path) const
{
  const FileContext context (path);
  VolumeHeader header{};
  std::memcpy (header.magic, kMagic, sizeof kMagic);
  header.version = kVersion;
  header.voxel_bytes = sizeof (TsdfVoxel);
  header.block_side = kBlockSide;
  header.voxel_size = config_.voxel_size;
  header.truncation_voxels = config_.truncation_voxels;
  header.max_weight = config_.max_weight;
  header.min_depth = config_.min_depth;
  header.max_depth = config_.max_depth;
  header.has_bounds = config_.bounds ? 1 : 0;
  if (config_.bounds)
    for (int i = 0; i < 3; ++i)
    {
      header.bounds[i] = config_.bounds->min ()[i];
      header.bounds[3 + i] = config_.bounds->max ()[i];
    }
  header.block_count = store_.size ();
  io::writeFileAtomic (path, [&] (const std::string& temporary) {
    std::ofstream out (temporary, std::ios::binary);
    out.write (reinterpret_cast<const char*> (&header), sizeof header);
    for (std::size_t id = 0; id < store_.size (); ++id)
    {
      const VoxelBlock& block = store_.block (id);
      const std::int32_t index[3] = {block.index.x (), block.index.y (), block.index.z ()};
      out.write (reinterpret_cast<const char*> (index), sizeof index);
      out.write (reinterpret_cast<const char*> (block.voxels.data ()), sizeof (TsdfVoxel) * kBlockVoxels);
    }
    out.close ();
    return static_cast<bool> (out);
  });
}

TSDFVolume
TSDFVolume::load (const std::string& path)
{
  const FileContext context (path);
  io::requireRegularFile (path);
  std::ifstream in (path, std::ios::binary);
  if (!in)
    throw Error (path, "cannot open volume file");
  VolumeHeader header{};
  in.read (reinterpret_cast<char*> (&header), sizeof header);
  if (!in || std::memcmp (header.magic, kMagic, sizeof kMagic) != 0)
    throw Error (path, "not a cuefusion volume file");
  if (header.version == 1)
    throw Error (path, "volume file version 1 (cuefusion 0.1, labels inside the voxels); this build reads version 2: "
                       "save the map again with this version");
  if (header.version != kVersion)
    throw Error (path, "volume file version " + std::to_string (header.version) + " (this build reads version " +
                         std::to_string (kVersion) + ")");
  if (header.voxel_bytes != sizeof (TsdfVoxel) || header.block_side != kBlockSide)
    throw Error (path, "volume file has another voxel layout");
  boost::system::error_code ec;
  const std::uint64_t size = boost::filesystem::file_size (path, ec);
  if (ec || header.block_count > (size - sizeof header) / kBlockRecordBytes ||
      size != sizeof header + header.block_count * kBlockRecordBytes)
    throw Error (path, "volume file is truncated or has trailing data");

  TSDFVolumeConfig config;
  config.voxel_size = header.voxel_size;
  config.truncation_voxels = header.truncation_voxels;
  config.max_weight = header.max_weight;
  config.min_depth = header.min_depth;
  config.max_depth = header.max_depth;
  if (header.has_bounds)
  {
    double b[6];  // the header is packed: its doubles are not aligned, Eigen takes them by reference
    std::memcpy (b, header.bounds, sizeof b);
    config.bounds = Eigen::AlignedBox3d (Eigen::Vector3d (b[0], b[1], b[2]), Eigen::Vector3d (b[3], b[4], b[5]));
  }
  try
  {
    config.validate ();
  }
  catch (const Error& e)
  {
    throw Error (path, std::string ("volume file holds an invalid configuration: ") + e.what ());
  }
  TSDFVolume volume (config);
  volume.store_.reserve (header.block_count);
  for (std::uint64_t i = 0; i < header.block_count; ++i)
  {
    std::int32_t index[3];
    in.read (reinterpret_cast<char*> (index), sizeof index);
    const Eigen::Vector3i b (index[0], index[1], index[2]);
    if (!in || !inBlockRange (b))
      throw Error (path, "volume file has a corrupt block record " + std::to_string (i));
    const auto [allocated, fresh] = volume.store_.allocate (b);
    if (!fresh)
      throw Error (path, "volume file lists block " + std::to_string (i) + " twice");
    const auto id = static_cast<std::size_t> (allocated);
    in.read (reinterpret_cast<char*> (volume.store_.block (id).voxels.data ()), sizeof (TsdfVoxel) * kBlockVoxels);
    if (!in)
      throw Error (path, "volume file is truncated in block " + std::to_string (i));
    // Its distances, and their copies in the aprons of the blocks below it read so far
    // (those read later take theirs from it when allocated).
    volume.store_.refreshDistances (id);
  }
  return volume;
}
}  // namespace reconstruction
}  // namespace cuefusion
