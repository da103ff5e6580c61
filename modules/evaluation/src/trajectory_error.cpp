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
TrajectoryError
absoluteTrajectoryError (const io::Trajectory& estimate, const io::Trajectory& reference, double max_time_difference,
                         bool align)
{
  io::Trajectory sorted = reference;
  std::sort (sorted.begin (), sorted.end (), [] (const io::StampedPose& a, const io::StampedPose& b) { return a.timestamp < b.timestamp; });
  std::vector<Eigen::Vector3d> est, ref;
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
    est.push_back (e.pose.translation ());
    ref.push_back (best->pose.translation ());
  }
  if (est.size () < 3)
    throw Error ("absoluteTrajectoryError", "fewer than three estimated poses have a reference pose at their time");

  TrajectoryError result;
  result.pairs = est.size ();
  if (align)
  {
    Eigen::Matrix3Xd src (3, est.size ()), dst (3, ref.size ());
    for (std::size_t i = 0; i < est.size (); ++i)
    {
      src.col (static_cast<Eigen::Index> (i)) = est[i];
      dst.col (static_cast<Eigen::Index> (i)) = ref[i];
    }
    result.alignment.matrix () = Eigen::umeyama (src, dst, false);
  }
  std::vector<double> errors (est.size ());
  double sum = 0.0, sum_sq = 0.0;
  for (std::size_t i = 0; i < est.size (); ++i)
  {
    errors[i] = (result.alignment * est[i] - ref[i]).norm ();
    sum += errors[i];
    sum_sq += errors[i] * errors[i];
  }
  result.rmse = std::sqrt (sum_sq / static_cast<double> (errors.size ()));
  result.mean = sum / static_cast<double> (errors.size ());
  result.max = *std::max_element (errors.begin (), errors.end ());
  std::nth_element (errors.begin (), errors.begin () + static_cast<std::ptrdiff_t> (errors.size () / 2), errors.end ());
  result.median = errors[errors.size () / 2];
  return result;
}
}  // namespace evaluation
}  // namespace cuefusion
