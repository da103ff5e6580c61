// SPDX-License-Identifier: BSD-3-Clause
#include <cuefusion/common/exceptions.h>
#include <cuefusion/evaluation/object_iou.h>

#include <algorithm>
#include <limits>
#include <unordered_map>

namespace cuefusion
{
namespace evaluation
{
std::vector<int>
maximumWeightAssignment (const Eigen::MatrixXd& weights)
{
  const bool transposed = weights.rows () > weights.cols ();
  // The potentials method below needs rows ≤ columns; minimise the negated weights.
  const Eigen::MatrixXd cost = transposed ? Eigen::MatrixXd (-weights.transpose ()) : Eigen::MatrixXd (-weights);
  const int n = static_cast<int> (cost.rows ()), m = static_cast<int> (cost.cols ());
  std::vector<int> result (static_cast<std::size_t> (weights.rows ()), -1);
  if (n == 0 || m == 0)
    return result;
  const double inf = std::numeric_limits<double>::infinity ();
  // 1-based arrays: p[j] = row assigned to column j (0 = none), u/v the dual potentials.
  std::vector<double> u (n + 1, 0.0), v (m + 1, 0.0);
  std::vector<int> p (m + 1, 0), way (m + 1, 0);
  for (int i = 1; i <= n; ++i)
  {
    p[0] = i;
    int j0 = 0;
    std::vector<double> minv (m + 1, inf);
    std::vector<char> used (m + 1, 0);
    do
    {
      used[j0] = 1;
      const int i0 = p[j0];
      double delta = inf;
      int j1 = 0;
      for (int j = 1; j <= m; ++j)
      {
        if (used[j])
          continue;
        const double reduced = cost (i0 - 1, j - 1) - u[i0] - v[j];
        if (reduced < minv[j])
        {
          minv[j] = reduced;
          way[j] = j0;
        }
        if (minv[j] < delta)
        {
          delta = minv[j];
          j1 = j;
        }
      }
      for (int j = 0; j <= m; ++j)
      {
        if (used[j])
        {
          u[p[j]] += delta;
          v[j] -= delta;
        }
        else
          minv[j] -= delta;
      }
      j0 = j1;
    } while (p[j0] != 0);
    do
    {
      const int j1 = way[j0];
      p[j0] = p[j1];
      j0 = j1;
    } while (j0 != 0);
  }
  for (int j = 1; j <= m; ++j)
  {
    if (p[j] == 0)
      continue;
    const int row = p[j] - 1, col = j - 1;
    const double w = transposed ? weights (col, row) : weights (row, col);
    if (w <= 0.0)
      continue;
    if (transposed)
      result[static_cast<std::size_t> (col)] = row;
    else
      result[static_cast<std::size_t> (row)] = col;
  }
  return result;
}

void
FrameIoUConfig::validate () const
{
  if (min_truth_pixels == 0)
    throw ParameterError ("FrameIoUConfig::min_truth_pixels", "must be at least 1");
}

namespace
{
cv::Mat
asLabels32 (const cv::Mat& labels, const char* what)
{
  if (labels.empty () || labels.channels () != 1 || (labels.depth () != CV_32S && labels.depth () != CV_16U))
    throw Error ("frameObjectIoU", std::string (what) + " must be a non-empty one-channel CV_32S or CV_16U image");
  if (labels.depth () == CV_32S)
    return labels;
  cv::Mat converted;
  labels.convertTo (converted, CV_32S);
  return converted;
}
}  // namespace

std::vector<ObjectIoU>
frameObjectIoU (const cv::Mat& predicted, const cv::Mat& truth, const cv::Mat& valid, const FrameIoUConfig& config)
{
  config.validate ();
  const cv::Mat pred = asLabels32 (predicted, "the predicted label image");
  const cv::Mat gt = asLabels32 (truth, "the ground-truth instance image");
  if (pred.size () != gt.size ())
    throw Error ("frameObjectIoU", "predicted labels and ground truth differ in size");
  if (!valid.empty () && (valid.type () != CV_8UC1 || valid.size () != gt.size ()))
    throw Error ("frameObjectIoU", "the valid mask must be CV_8UC1 of the labels' size");

  std::unordered_map<std::uint64_t, std::size_t> intersections;
  std::unordered_map<std::uint32_t, std::size_t> truth_size, pred_size;
  for (int r = 0; r < gt.rows; ++r)
  {
    const std::int32_t* g = gt.ptr<std::int32_t> (r);
    const std::int32_t* p = pred.ptr<std::int32_t> (r);
    const std::uint8_t* m = valid.empty () ? nullptr : valid.ptr<std::uint8_t> (r);
    for (int c = 0; c < gt.cols; ++c)
    {
      if (m && !m[c])
        continue;
      const auto t = static_cast<std::uint32_t> (g[c]), s = static_cast<std::uint32_t> (p[c]);
      if (t)
        ++truth_size[t];
      if (s)
        ++pred_size[s];
      if (t && s)
        ++intersections[(static_cast<std::uint64_t> (t) << 32) | s];
    }
  }
  std::vector<std::uint32_t> objects, segments;
  for (const auto& [id, n] : truth_size)
    if (n >= config.min_truth_pixels)
      objects.push_back (id);
  for (const auto& [id, n] : pred_size)
    segments.push_back (id);
  std::sort (objects.begin (), objects.end ());
  std::sort (segments.begin (), segments.end ());
  std::unordered_map<std::uint32_t, int> column;
  for (std::size_t j = 0; j < segments.size (); ++j)
    column[segments[j]] = static_cast<int> (j);

  Eigen::MatrixXd iou = Eigen::MatrixXd::Zero (static_cast<Eigen::Index> (objects.size ()), static_cast<Eigen::Index> (segments.size ()));
  std::unordered_map<std::uint32_t, int> row;
  for (std::size_t i = 0; i < objects.size (); ++i)
    row[objects[i]] = static_cast<int> (i);
  for (const auto& [key, n] : intersections)
  {
    const auto t = static_cast<std::uint32_t> (key >> 32), s = static_cast<std::uint32_t> (key & 0xffffffffu);
    const auto r = row.find (t);
    if (r == row.end ())
      continue;
    iou (r->second, column[s]) = static_cast<double> (n) / static_cast<double> (truth_size[t] + pred_size[s] - n);
  }
  const std::vector<int> match = maximumWeightAssignment (iou);
  std::vector<ObjectIoU> result;
  for (std::size_t i = 0; i < objects.size (); ++i)
  {
    ObjectIoU o;
    o.instance = objects[i];
    o.truth_pixels = truth_size[objects[i]];
    if (match[i] >= 0)
    {
      const std::uint32_t s = segments[static_cast<std::size_t> (match[i])];
      o.segment = static_cast<std::int32_t> (s);
      o.segment_pixels = pred_size[s];
      o.iou = iou (static_cast<Eigen::Index> (i), match[i]);
      o.intersection = intersections[(static_cast<std::uint64_t> (objects[i]) << 32) | s];
    }
    result.push_back (o);
  }
  return result;
}

SequenceIoU
summarizeObjectIoU (const std::vector<std::vector<ObjectIoU>>& frames)
{
  std::map<std::uint32_t, double> sums;
  SequenceIoU result;
  for (const auto& frame : frames)
    for (const ObjectIoU& o : frame)
    {
      sums[o.instance] += o.iou;
      ++result.object_frames[o.instance];
    }
  for (const auto& [id, sum] : sums)
  {
    result.object_mean[id] = sum / static_cast<double> (result.object_frames[id]);
    result.mean += result.object_mean[id];
  }
  if (!sums.empty ())
    result.mean /= static_cast<double> (sums.size ());
  return result;
}
}  // namespace evaluation
}  // namespace cuefusion
