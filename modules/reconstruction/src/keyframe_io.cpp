// SPDX-License-Identifier: BSD-3-Clause
// Keyframe database files: a fixed little-endian header, the fern tests, then every
// keyframe's pose and code (beside volume.tsdf; `run --save-volume`, `--load-volume`). The
// header names the volume the poses are in (voxel size, TSDFVolume::fingerprint).
#include <cuefusion/common/exceptions.h>
#include <cuefusion/io/file_io.h>
#include <cuefusion/io/pose_io.h>
#include <cuefusion/reconstruction/keyframe_database.h>
#include <cuefusion/reconstruction/tsdf_volume.h>

#include <boost/filesystem.hpp>

#include <cmath>
#include <cstring>
#include <fstream>
#include <sstream>

namespace cuefusion
{
namespace reconstruction
{
namespace
{
constexpr char kMagic[8] = {'C', 'F', 'K', 'E', 'Y', 'F', '\r', '\n'};
// Version 1 did not name its volume; version 2 adds the volume's voxel size and fingerprint.
constexpr std::uint32_t kVersion = 2;

#pragma pack(push, 1)
struct KeyframeHeader
{
  char magic[8];
  std::uint32_t version;
  std::int32_t ferns, decisions, width, height;
  double max_depth, min_novelty;
  std::uint64_t max_keyframes;
  std::uint32_t seed;
  std::uint64_t keyframes;
  double voxel_size;                ///< the volume's (TSDFVolumeConfig::voxel_size)
  std::uint64_t volume_fingerprint;  ///< TSDFVolume::fingerprint of the volume
};
struct TestRecord
{
  std::int32_t x, y;
  float threshold;
};
#pragma pack(pop)

constexpr std::size_t kPoseBytes = 12 * sizeof (double);  ///< the 3×4 [R | t], row by row

static_assert (sizeof (float) == 4 && sizeof (double) == 8, "keyframe files assume IEEE-754 floats");
}  // namespace

void
KeyframeDatabase::save (const std::string& path, const TSDFVolume& volume) const
{
  const FileContext context (path);
  KeyframeHeader header{};
  std::memcpy (header.magic, kMagic, sizeof kMagic);
  header.version = kVersion;
  header.ferns = config_.ferns;
  header.decisions = config_.decisions;
  header.width = config_.size.width;
  header.height = config_.size.height;
  header.max_depth = config_.max_depth;
  header.min_novelty = config_.min_novelty;
  header.max_keyframes = config_.max_keyframes;
  header.seed = config_.seed;
  header.keyframes = codes_.size ();
  header.voxel_size = volume.getConfig ().voxel_size;
  header.volume_fingerprint = volume.fingerprint ();
  io::writeFileAtomic (path, [&] (const std::string& temporary) {
    std::ofstream out (temporary, std::ios::binary);
    out.write (reinterpret_cast<const char*> (&header), sizeof header);
    for (const Test& t : tests_)
    {
      const TestRecord record{t.x, t.y, t.threshold};
      out.write (reinterpret_cast<const char*> (&record), sizeof record);
    }
    for (std::size_t k = 0; k < codes_.size (); ++k)
    {
      double pose[12];
      for (int r = 0; r < 3; ++r)
        for (int c = 0; c < 4; ++c)
          pose[r * 4 + c] = poses_[k].matrix () (r, c);
      out.write (reinterpret_cast<const char*> (pose), sizeof pose);
      out.write (reinterpret_cast<const char*> (codes_[k].data ()), static_cast<std::streamsize> (codes_[k].size ()));
    }
    out.close ();
    return static_cast<bool> (out);
  });
}

KeyframeDatabase
KeyframeDatabase::load (const std::string& path, const TSDFVolume& volume)
{
  const FileContext context (path);
  io::requireRegularFile (path);
  std::ifstream in (path, std::ios::binary);
  if (!in)
    throw Error (path, "cannot open keyframe file");
  KeyframeHeader header{};
  in.read (reinterpret_cast<char*> (&header), sizeof header);
  if (!in || std::memcmp (header.magic, kMagic, sizeof kMagic) != 0)
    throw Error (path, "not a cuefusion keyframe file");
  if (header.version == 1)
    throw Error (path, "keyframe file version 1 does not name its volume; this build reads version 2: save the "
                       "volume again with this version");
  if (header.version != kVersion)
    throw Error (path, "keyframe file version " + std::to_string (header.version) + " (this build reads version " +
                         std::to_string (kVersion) + ")");
  KeyframeDatabaseConfig config;
  config.ferns = header.ferns;
  config.decisions = header.decisions;
  config.size = cv::Size (header.width, header.height);
  config.max_depth = header.max_depth;
  config.min_novelty = header.min_novelty;
  config.max_keyframes = static_cast<std::size_t> (header.max_keyframes);
  config.seed = header.seed;
  try
  {
    config.validate ();
  }
  catch (const Error& e)
  {
    throw Error (path, std::string ("keyframe file holds an invalid configuration: ") + e.what ());
  }
  // The sizes are bounded now (ferns ≤ 10000, decisions ≤ 8): the products cannot overflow.
  const std::uint64_t tests = static_cast<std::uint64_t> (config.ferns) * static_cast<std::uint64_t> (config.decisions);
  const std::uint64_t record = kPoseBytes + static_cast<std::uint64_t> (config.ferns);
  boost::system::error_code ec;
  const std::uint64_t size = boost::filesystem::file_size (path, ec);
  const std::uint64_t fixed = sizeof header + tests * sizeof (TestRecord);
  if (ec || size < fixed || header.keyframes > (size - fixed) / record || size != fixed + header.keyframes * record)
    throw Error (path, "keyframe file is truncated or has trailing data");
  if (header.keyframes > config.max_keyframes)
    throw Error (path, "keyframe file holds more keyframes than its max_keyframes");

  KeyframeDatabase database (config);  // draws tests from the seed; replaced by the stored ones
  for (std::size_t i = 0; i < database.tests_.size (); ++i)
  {
    TestRecord t{};
    in.read (reinterpret_cast<char*> (&t), sizeof t);
    if (!in || t.x < 0 || t.x >= config.size.width || t.y < 0 || t.y >= config.size.height ||
        !(t.threshold >= 0.f && t.threshold <= static_cast<float> (config.max_depth)))
      throw Error (path, "keyframe file has a corrupt test " + std::to_string (i));
    database.tests_[i] = {t.x, t.y, t.threshold};
  }
  const std::uint8_t code_end = static_cast<std::uint8_t> ((1u << config.decisions) - 1u);
  for (std::uint64_t k = 0; k < header.keyframes; ++k)
  {
    double pose[12];
    Code code (static_cast<std::size_t> (config.ferns));
    in.read (reinterpret_cast<char*> (pose), sizeof pose);
    in.read (reinterpret_cast<char*> (code.data ()), static_cast<std::streamsize> (code.size ()));
    if (!in)
      throw Error (path, "keyframe file is truncated in keyframe " + std::to_string (k));
    Eigen::Matrix4d m = Eigen::Matrix4d::Identity ();
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < 4; ++c)
        m (r, c) = pose[r * 4 + c];
    const Eigen::Isometry3d p = io::rigidFromMatrix (m, path + ", keyframe " + std::to_string (k));
    for (const std::uint8_t bits : code)
      if (bits > code_end)
        throw Error (path, "keyframe " + std::to_string (k) + " has a code of more than " + std::to_string (config.decisions) + " bits");
    database.codes_.push_back (std::move (code));
    database.poses_.push_back (p);
  }
  // Checked last, so that a file's own damage is reported as such.
  const double voxel_size = header.voxel_size, volume_voxel = volume.getConfig ().voxel_size;
  if (voxel_size != volume_voxel)
  {
    std::ostringstream why;
    why << "keyframe file was saved with a volume of " << voxel_size << " m voxels, its volume has " << volume_voxel << " m";
    throw Error (path, why.str ());
  }
  if (header.volume_fingerprint != volume.fingerprint ())
    throw Error (path, "keyframe file was saved with another volume (another run's map, or an earlier save): its poses "
                       "would place the camera wrongly");
  return database;
}
}  // namespace reconstruction
}  // namespace cuefusion
