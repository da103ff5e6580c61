// SPDX-License-Identifier: BSD-3-Clause
#include <cuefusion/common/exceptions.h>
#include <cuefusion/evaluation/trajectory_error.h>

#include <Eigen/Geometry>

#include <algorithm>
#include <cmath>
#include <vector>

namespace cuefusion
{
namespace evaluation
{
namespace
{
double
medianOf (std::vector<double> values)
{
  std::nth_element (values.begin (), values.begin () + static_cast<std::ptrdiff_t> (values.size () / 2), values.end ());
  return values[values.size () / 2];
}

double
rmsOf (const std::vector<double>& values)
{
  double sum_sq = 0.0;
  for (const double v : values)
    sum_sq += v * v;
  return std::sqrt (sum_sq / static_cast<double> (values.size ()));
}
}  // namespace

PosePairs
associatePoses (const io::Trajectory& estimate, const io::Trajectory& reference, double max_time_difference)
{
  io::Trajectory sorted = reference;
  std::sort (sorted.begin (), sorted.end (), [] (const io::StampedPose& a, const io::StampedPose& b) { return a.timestamp < b.timestamp; });
  PosePairs pairs;
  for (const io::StampedPose& e : estimate)
  {
    const auto it = std::lower_bound (sorted.begin (), sorted.end (), e.timestamp,
                                      [] (const io::StampedPose& p, double t) { return p.timestamp < t; });
    const io::StampedPose* best = nullptr;
    if (it != sorted.end ())
      best = &*it;
    if (it != sorted.begin () && (best == nullptr || e.timestamp - (it - 1)->timestamp < best->timestamp - e.timestamp))
      best = &*(it - 1);
    if (best == nullptr || std::abs (best->timestamp - e.timestamp) > max_time_difference)
      continue;
    pairs.push_back ({e.timestamp, e.pose, best->pose});
  }
  return pairs;
}

TrajectoryError
absoluteTrajectoryError (const io::Trajectory& estimate, const io::Trajectory& reference, double max_time_difference,
                         bool align)
{
  const PosePairs pairs = associatePoses (estimate, reference, max_time_difference);
  if (pairs.size () < 3)
    throw Error ("absoluteTrajectoryError", "fewer than three estimated poses have a reference pose at their time");

  TrajectoryError result;
  result.pairs = pairs.size ();
  if (align)
  {
    Eigen::Matrix3Xd src (3, pairs.size ()), dst (3, pairs.size ());
    for (std::size_t i = 0; i < pairs.size (); ++i)
    {
      src.col (static_cast<Eigen::Index> (i)) = pairs[i].estimate.translation ();
      dst.col (static_cast<Eigen::Index> (i)) = pairs[i].reference.translation ();
    }
    result.alignment.matrix () = Eigen::umeyama (src, dst, false);
  }
  std::vector<double> errors (pairs.size ());
  for (std::size_t i = 0; i < pairs.size (); ++i)
    errors[i] = (result.alignment * pairs[i].estimate.translation () - pairs[i].reference.translation ()).norm ();
  result.rmse = rmsOf (errors);
  double sum = 0.0;
  for (const double e : errors)
    sum += e;
  result.mean = sum / static_cast<double> (errors.size ());
  result.max = *std::max_element (errors.begin (), errors.end ());
  result.median = medianOf (errors);
  return result;
}

RelativePoseError
relativePoseError (const io::Trajectory& estimate, const io::Trajectory& reference, const RelativePoseInterval& interval,
                   double max_time_difference)
{
  if (!(interval.length > 0.0))
    throw ParameterError ("relativePoseError", "the interval must be positive");
  PosePairs pairs = associatePoses (estimate, reference, max_time_difference);
  std::sort (pairs.begin (), pairs.end (), [] (const PosePair& a, const PosePair& b) { return a.timestamp < b.timestamp; });
  std::vector<double> translation, rotation;
  const std::size_t step = static_cast<std::size_t> (std::max (1.0, std::round (interval.length)));
  for (std::size_t i = 0; i < pairs.size (); ++i)
  {
    std::size_t j = pairs.size ();
    if (interval.unit == RelativePoseInterval::Unit::Frames)
      j = i + step;
    else
    {
      const double target = pairs[i].timestamp + interval.length;
      j = static_cast<std::size_t> (std::lower_bound (pairs.begin () + static_cast<std::ptrdiff_t> (i), pairs.end (), target - 1e-9,
                                                      [] (const PosePair& p, double t) { return p.timestamp < t; }) -
                                    pairs.begin ());
    }
    if (j >= pairs.size ())
      break;
    const Eigen::Isometry3d reference_motion = pairs[i].reference.inverse () * pairs[j].reference;
    const Eigen::Isometry3d estimated_motion = pairs[i].estimate.inverse () * pairs[j].estimate;
    const Eigen::Isometry3d error = reference_motion.inverse () * estimated_motion;
    translation.push_back (error.translation ().norm ());
    rotation.push_back (Eigen::AngleAxisd (error.rotation ()).angle () * 180.0 / M_PI);
  }
  if (translation.empty ())
    throw Error ("relativePoseError", "no pair of poses spans the interval (too few poses or too short a sequence)");
  RelativePoseError result;
  result.pairs = translation.size ();
  result.translation_rmse = rmsOf (translation);
  result.translation_median = medianOf (translation);
  result.rotation_rmse_deg = rmsOf (rotation);
  result.rotation_median_deg = medianOf (rotation);
  return result;
}
}  // namespace evaluation
}  // namespace cuefusion
