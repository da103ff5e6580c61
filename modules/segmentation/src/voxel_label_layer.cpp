// SPDX-License-Identifier: BSD-3-Clause
// The segmentation's label layer beside the TSDF volume, and its files.
#include <cuefusion/common/exceptions.h>
#include <cuefusion/common/parallel.h>
#include <cuefusion/io/file_io.h>
#include <cuefusion/segmentation/voxel_label_layer.h>

#include <boost/filesystem.hpp>

#include <cstring>
#include <fstream>

namespace cuefusion
{
namespace segmentation
{
namespace
{
constexpr char kMagic[8] = {'C', 'F', 'L', 'A', 'B', 'E', 'L', '\n'};
constexpr std::uint32_t kVersion = 1;
constexpr std::size_t kVoxels = reconstruction::kBlockVoxels;

#pragma pack(push, 1)
struct LabelFileHeader
{
  char magic[8];
  std::uint32_t version;
  std::uint32_t block_side;  ///< kBlockSide
  std::uint64_t block_count;
};
#pragma pack(pop)

// A record: the block's coordinates (3 × int32), its labels (uint32 each), its Ψ (a byte each).
constexpr std::size_t kRecordBytes = 3 * sizeof (std::int32_t) + kVoxels * (sizeof (std::uint32_t) + sizeof (std::uint8_t));

bool
labelled (const VoxelLabelLayer::Block& block)
{
  for (const std::uint32_t label : block.labels)
    if (label != 0)
      return true;
  return false;
}
}  // namespace

void
VoxelLabelLayer::resize (std::size_t blocks)
{
  blocks_.reserve (blocks);
  label_values_.blocks.reserve (blocks);
  while (blocks_.size () < blocks)
  {
    blocks_.push_back (std::make_unique<Block> ());
    label_values_.blocks.push_back (blocks_.back ()->labels.data ());
  }
}

void
VoxelLabelLayer::labelImage (const cv::Mat& voxels, cv::Mat& labels) const
{
  if (voxels.type () != CV_32S)
    throw Error ("VoxelLabelLayer::labelImage", "voxel numbers must be CV_32S (RaycastResult::voxels)");
  labels.create (voxels.size (), CV_32S);
  // The voxels a view hits are scattered over the layer and mostly out of cache: each
  // lookup is prefetched a few pixels ahead (without, this loop waited on memory for
  // 0.8 ms a frame on the real sequences).
  constexpr int kAhead = 32;
  parallelForChunks (voxels.rows, 16, [&] (int, int begin, int end) {
    for (int y = begin; y < end; ++y)
    {
      const std::int32_t* in = voxels.ptr<std::int32_t> (y);
      std::int32_t* out = labels.ptr<std::int32_t> (y);
      for (int x = 0; x < voxels.cols; ++x)
      {
        if (x + kAhead < voxels.cols)
        {
          const auto ahead = static_cast<reconstruction::VoxelNumber> (in[x + kAhead]);
          const std::size_t id = ahead / reconstruction::kBlockVoxels;
          if (ahead != reconstruction::kNoVoxel && id < blocks_.size ())
            __builtin_prefetch (&blocks_[id]->labels[ahead % reconstruction::kBlockVoxels]);
        }
        out[x] = static_cast<std::int32_t> (label (static_cast<reconstruction::VoxelNumber> (in[x])));
      }
    }
  });
}

void
VoxelLabelLayer::save (const std::string& path, const reconstruction::TSDFVolume& volume,
                       const std::function<std::uint32_t (std::uint32_t)>& label_map) const
{
  const FileContext context (path);
  if (blocks_.size () > volume.blockCount ())
    throw Error (path, "the label layer has more blocks than its volume");
  std::vector<std::size_t> written;
  for (std::size_t id = 0; id < blocks_.size (); ++id)
    if (labelled (*blocks_[id]))
      written.push_back (id);
  LabelFileHeader header{};
  std::memcpy (header.magic, kMagic, sizeof kMagic);
  header.version = kVersion;
  header.block_side = reconstruction::kBlockSide;
  header.block_count = written.size ();
  io::writeFileAtomic (path, [&] (const std::string& temporary) {
    std::ofstream out (temporary, std::ios::binary);
    out.write (reinterpret_cast<const char*> (&header), sizeof header);
    std::array<std::uint32_t, kVoxels> mapped;
    for (const std::size_t id : written)
    {
      const Eigen::Vector3i& b = volume.store ().block (id).index;
      const std::int32_t index[3] = {b.x (), b.y (), b.z ()};
      out.write (reinterpret_cast<const char*> (index), sizeof index);
      const Block& block = *blocks_[id];
      for (std::size_t i = 0; i < kVoxels; ++i)
        mapped[i] = label_map && block.labels[i] != 0 ? label_map (block.labels[i]) : block.labels[i];
      out.write (reinterpret_cast<const char*> (mapped.data ()), sizeof mapped);
      out.write (reinterpret_cast<const char*> (block.confidence.data ()), sizeof block.confidence);
    }
    out.close ();
    return static_cast<bool> (out);
  });
}

VoxelLabelLayer
VoxelLabelLayer::load (const std::string& path, const reconstruction::TSDFVolume& volume)
{
  const FileContext context (path);
  io::requireRegularFile (path);
  std::ifstream in (path, std::ios::binary);
  if (!in)
    throw Error (path, "cannot open label file");
  LabelFileHeader header{};
  in.read (reinterpret_cast<char*> (&header), sizeof header);
  if (!in || std::memcmp (header.magic, kMagic, sizeof kMagic) != 0)
    throw Error (path, "not a cuefusion label file");
  if (header.version != kVersion)
    throw Error (path, "label file version " + std::to_string (header.version) + " (this build reads version " +
                         std::to_string (kVersion) + ")");
  if (header.block_side != reconstruction::kBlockSide)
    throw Error (path, "label file has another block size");
  boost::system::error_code ec;
  const std::uint64_t size = boost::filesystem::file_size (path, ec);
  if (ec || header.block_count > (size - sizeof header) / kRecordBytes || size != sizeof header + header.block_count * kRecordBytes)
    throw Error (path, "label file is truncated or has trailing data");

  VoxelLabelLayer layer;
  layer.resize (volume.blockCount ());
  std::vector<bool> seen (volume.blockCount (), false);
  for (std::uint64_t i = 0; i < header.block_count; ++i)
  {
    std::int32_t index[3];
    in.read (reinterpret_cast<char*> (index), sizeof index);
    const std::int32_t id = in ? volume.store ().findBlock (Eigen::Vector3i (index[0], index[1], index[2])) : -1;
    if (id < 0)
      throw Error (path, "label file lists block " + std::to_string (i) + ", which its volume does not have");
    if (seen[static_cast<std::size_t> (id)])
      throw Error (path, "label file lists block " + std::to_string (i) + " twice");
    seen[static_cast<std::size_t> (id)] = true;
    Block& block = layer.block (static_cast<std::size_t> (id));
    in.read (reinterpret_cast<char*> (block.labels.data ()), sizeof block.labels);
    in.read (reinterpret_cast<char*> (block.confidence.data ()), sizeof block.confidence);
    if (!in)
      throw Error (path, "label file is truncated in block " + std::to_string (i));
  }
  return layer;
}
}  // namespace segmentation
}  // namespace cuefusion
