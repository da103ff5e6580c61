// SPDX-License-Identifier: BSD-3-Clause
#pragma once

#include <cuefusion/common/sensor_defaults.h>

#include <Eigen/Geometry>
#include <opencv2/core.hpp>

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

namespace cuefusion
{
namespace reconstruction
{
class TSDFVolume;

/** \brief Parameters of KeyframeDatabase (defaults after InfiniTAM's relocaliser). */
struct KeyframeDatabaseConfig
{
  int ferns = 500;                  ///< random ferns
  int decisions = 4;                ///< binary tests per fern (a code of this many bits)
  cv::Size size{80, 60};            ///< the depth is reduced to this before the tests
  double max_depth = kMaxDepth;       ///< test thresholds are drawn in (0, max_depth] metres
  /** A tracked frame becomes a keyframe when every stored keyframe differs from it in at
    * least this share of its fern codes. */
  double min_novelty = 0.2;
  std::size_t max_keyframes = 2000;  ///< then the database stops growing
  std::uint32_t seed = 42;          ///< of the fern tests

  void validate () const;
};

/** \brief A keyframe database for relocalisation with random ferns (Glocker et al., "Real-time
  * RGB-D camera relocalization via randomized ferns for keyframe encoding", TVCG 2015;
  * InfiniTAM's FernRelocLib): a frame is coded by `ferns` groups of `decisions` random
  * tests "is the reduced depth at pixel p below threshold t"; two frames are as
  * dissimilar as the share of ferns whose codes differ. Tracked frames that differ from
  * every keyframe by at least min_novelty are added with their pose; a lost frame asks
  * for the poses of the most similar keyframes, which the caller verifies (by ICP
  * against the model) before it trusts one.
  *
  * Depth only: it transfers between real and rendered data and ignores lighting. The
  * reduction averages the valid depth of each cell (a cell without any is "missing",
  * which fails every test), so the code survives noise and small shifts.
  */
class KeyframeDatabase
{
public:
  using Ptr = std::shared_ptr<KeyframeDatabase>;
  using Code = std::vector<std::uint8_t>;  ///< one code per fern

  /** \brief A stored keyframe, as returned by query(). */
  struct Match
  {
    Eigen::Isometry3d pose = Eigen::Isometry3d::Identity ();  ///< camera-to-world
    double dissimilarity = 1.0;  ///< share of ferns whose codes differ
    std::size_t keyframe = 0;    ///< its index, in the order added
  };

  explicit KeyframeDatabase (const KeyframeDatabaseConfig& config = KeyframeDatabaseConfig ());

  const KeyframeDatabaseConfig& getConfig () const { return config_; }

  /** \brief The fern code of a depth image (CV_32F metres, 0 or NaN = missing). */
  Code
  encode (const cv::Mat& depth) const;

  /** \brief Stores \a code with \a pose when no keyframe is closer than min_novelty;
    * returns whether it did. */
  bool
  addIfNovel (const Code& code, const Eigen::Isometry3d& pose);

  /** \brief Stores \a code with \a pose however similar it is to the stored keyframes
    * (while fewer than max_keyframes are stored); returns whether it did. */
  bool
  add (const Code& code, const Eigen::Isometry3d& pose);

  /** \brief The \a k stored keyframes most similar to \a code, most similar first. */
  std::vector<Match>
  query (const Code& code, std::size_t k) const;

  std::size_t size () const { return poses_.size (); }

  /** \brief Forgets every keyframe (the tests stay). */
  void clear ();

  /** \brief Writes the configuration, the tests and every keyframe (pose and code) in a
    * versioned little-endian binary format, with the voxel size and fingerprint of the
    * \a volume the keyframes' poses are in (saved beside it); atomic (temporary file, then
    * rename). The tests are stored, not re-drawn from the seed, so a file reads back the
    * same on any standard library. Throws cuefusion::Error naming the file.
    */
  void
  save (const std::string& path, const TSDFVolume& volume) const;

  /** \brief Reads a database written by save() beside \a volume; throws cuefusion::Error
    * naming the file when it is missing, of another format or version, truncated, holds
    * an invalid configuration, test, pose or code, or was saved with another volume
    * (another voxel size, another run's map: TSDFVolume::fingerprint).
    */
  static KeyframeDatabase
  load (const std::string& path, const TSDFVolume& volume);

private:
  struct Test
  {
    int x = 0, y = 0;       ///< cell of the reduced depth
    float threshold = 0.f;  ///< metres
  };
  double dissimilarity (const Code& a, std::size_t keyframe) const;

  KeyframeDatabaseConfig config_;
  std::vector<Test> tests_;  ///< ferns × decisions
  std::vector<Code> codes_;
  std::vector<Eigen::Isometry3d, Eigen::aligned_allocator<Eigen::Isometry3d>> poses_;
};
}  // namespace reconstruction
}  // namespace cuefusion
