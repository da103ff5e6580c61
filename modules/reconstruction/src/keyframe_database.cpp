// SPDX-License-Identifier: BSD-3-Clause
#include <cuefusion/common/exceptions.h>
#include <cuefusion/reconstruction/keyframe_database.h>

#include <algorithm>
#include <cmath>
#include <numeric>
#include <random>

namespace cuefusion
{
namespace reconstruction
{
void
KeyframeDatabaseConfig::validate () const
{
  if (ferns < 1 || ferns > 10000)
    throw ParameterError ("KeyframeDatabaseConfig::ferns", "must lie in [1, 10000]");
  if (decisions < 1 || decisions > 8)
    throw ParameterError ("KeyframeDatabaseConfig::decisions", "must lie in [1, 8] (a code is one byte)");
  if (size.width < 4 || size.height < 4 || size.width > 640 || size.height > 480)
    throw ParameterError ("KeyframeDatabaseConfig::size", "must lie between 4×4 and 640×480");
  if (!(max_depth > 0.0 && max_depth <= 100.0))
    throw ParameterError ("KeyframeDatabaseConfig::max_depth", "must lie in (0, 100] metres");
  if (!(min_novelty >= 0.0 && min_novelty <= 1.0))
    throw ParameterError ("KeyframeDatabaseConfig::min_novelty", "must lie in [0, 1]");
}

KeyframeDatabase::KeyframeDatabase (const KeyframeDatabaseConfig& config) : config_ (config)
{
  config_.validate ();
  std::mt19937 random (config_.seed);
  std::uniform_int_distribution<int> x (0, config_.size.width - 1), y (0, config_.size.height - 1);
  std::uniform_real_distribution<float> threshold (0.f, static_cast<float> (config_.max_depth));
  tests_.resize (static_cast<std::size_t> (config_.ferns * config_.decisions));
  for (Test& t : tests_)
  {
    t.x = x (random);
    t.y = y (random);
    t.threshold = threshold (random);
  }
}

KeyframeDatabase::Code
KeyframeDatabase::encode (const cv::Mat& depth) const
{
  if (depth.type () != CV_32F || depth.empty ())
    throw Error ("KeyframeDatabase::encode", "needs a CV_32F depth image");
  // Mean valid depth per cell of the reduced image (missing depth does not count); one
  // pass over the image, no temporary images (0.4 ms at 640×480 on the 2-core machine).
  const int cw = config_.size.width, ch = config_.size.height;
  std::vector<int> column_cell (static_cast<std::size_t> (depth.cols)), cell_columns (static_cast<std::size_t> (cw), 0);
  for (int u = 0; u < depth.cols; ++u)
    ++cell_columns[static_cast<std::size_t> (column_cell[static_cast<std::size_t> (u)] = std::min (cw - 1, u * cw / depth.cols))];
  std::vector<float> sums (static_cast<std::size_t> (cw * ch), 0.f), counts (sums.size (), 0.f), area (sums.size (), 0.f);
  for (int v = 0; v < depth.rows; ++v)
  {
    const float* row = depth.ptr<float> (v);
    const int cy = std::min (ch - 1, v * ch / depth.rows);
    for (int cx = 0; cx < cw; ++cx)
      area[static_cast<std::size_t> (cy * cw + cx)] += static_cast<float> (cell_columns[static_cast<std::size_t> (cx)]);
    for (int u = 0; u < depth.cols; ++u)
      if (row[u] > 0.f)  // false for NaN too
      {
        const auto cell = static_cast<std::size_t> (cy * cw + column_cell[static_cast<std::size_t> (u)]);
        sums[cell] += row[u];
        counts[cell] += 1.f;
      }
  }
  Code code (static_cast<std::size_t> (config_.ferns), 0);
  for (int f = 0; f < config_.ferns; ++f)
  {
    std::uint8_t bits = 0;
    for (int d = 0; d < config_.decisions; ++d)
    {
      const Test& t = tests_[static_cast<std::size_t> (f * config_.decisions + d)];
      const auto cell = static_cast<std::size_t> (t.y * cw + t.x);
      // A cell less than a quarter covered by valid depth is missing: it fails every test.
      const bool below = counts[cell] > 0.25f * area[cell] && sums[cell] / counts[cell] < t.threshold;
      bits = static_cast<std::uint8_t> (bits | (below ? 1u << d : 0u));
    }
    code[static_cast<std::size_t> (f)] = bits;
  }
  return code;
}

double
KeyframeDatabase::dissimilarity (const Code& a, std::size_t keyframe) const
{
  const Code& b = codes_[keyframe];
  std::size_t differ = 0;
  for (std::size_t f = 0; f < a.size (); ++f)
    differ += a[f] != b[f] ? 1 : 0;
  return static_cast<double> (differ) / static_cast<double> (a.size ());
}

bool
KeyframeDatabase::addIfNovel (const Code& code, const Eigen::Isometry3d& pose)
{
  if (code.size () != static_cast<std::size_t> (config_.ferns))
    throw Error ("KeyframeDatabase::addIfNovel", "code of another database");
  for (std::size_t k = 0; k < codes_.size (); ++k)
    if (dissimilarity (code, k) < config_.min_novelty)
      return false;
  return add (code, pose);
}

bool
KeyframeDatabase::add (const Code& code, const Eigen::Isometry3d& pose)
{
  if (code.size () != static_cast<std::size_t> (config_.ferns))
    throw Error ("KeyframeDatabase::add", "code of another database");
  if (codes_.size () >= config_.max_keyframes)
    return false;
  codes_.push_back (code);
  poses_.push_back (pose);
  return true;
}

std::vector<KeyframeDatabase::Match>
KeyframeDatabase::query (const Code& code, std::size_t k) const
{
  if (code.size () != static_cast<std::size_t> (config_.ferns))
    throw Error ("KeyframeDatabase::query", "code of another database");
  std::vector<Match> all;
  for (std::size_t i = 0; i < codes_.size (); ++i)
    all.push_back ({poses_[i], dissimilarity (code, i), i});
  std::stable_sort (all.begin (), all.end (), [] (const Match& a, const Match& b) { return a.dissimilarity < b.dissimilarity; });
  if (all.size () > k)
    all.resize (k);
  return all;
}

void
KeyframeDatabase::clear ()
{
  codes_.clear ();
  poses_.clear ();
}
}  // namespace reconstruction
}  // namespace cuefusion
