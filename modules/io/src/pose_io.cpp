// SPDX-License-Identifier: BSD-3-Clause
#include <cuefusion/common/exceptions.h>
#include <cuefusion/io/file_io.h>
#include <cuefusion/io/pose_io.h>

#include <algorithm>
#include <cmath>
#include <iomanip>
#include <sstream>

namespace cuefusion
{
namespace io
{
namespace
{
std::string
formatMatrix (const Eigen::Matrix4d& m)
{
  std::ostringstream out;
  out << std::setprecision (17);
  for (int r = 0; r < 4; ++r)
    out << m (r, 0) << " " << m (r, 1) << " " << m (r, 2) << " " << m (r, 3) << "\n";
  return out.str ();
}
}  // namespace

Eigen::Isometry3d
rigidFromMatrix (const Eigen::Matrix4d& m, const std::string& where)
{
  if (!m.allFinite ())
    throw Error (where, "pose holds non-finite values");
  const Eigen::Matrix3d r = m.topLeftCorner<3, 3> ();
  // Reference poses are often stored with 6-8 digits, so allow a little slack.
  const double orthonormality = (r.transpose () * r - Eigen::Matrix3d::Identity ()).cwiseAbs ().maxCoeff ();
  if (orthonormality > 1e-3 || r.determinant () < 0.0)
    throw Error (where, "pose is not a rigid transform (rotation not orthonormal)");
  if ((m.row (3) - Eigen::RowVector4d (0, 0, 0, 1)).cwiseAbs ().maxCoeff () > 1e-6)
    throw Error (where, "pose's last row is not 0 0 0 1");
  Eigen::Isometry3d pose;
  pose.matrix () = m;
  return pose;
}

std::optional<Eigen::Isometry3d>
readPoseMatrixFile (const std::string& path)
{
  const FileContext context (path);
  const std::vector<double> n = readNumbers (path);
  if (n.size () != 16)
    throw Error (path, "expected a 4x4 pose matrix (16 numbers), found " + std::to_string (n.size ()));
  Eigen::Matrix4d m;
  for (int i = 0; i < 16; ++i)
    m (i / 4, i % 4) = n[static_cast<std::size_t> (i)];
  if (!m.allFinite ())
    return std::nullopt;
  return rigidFromMatrix (m, path);
}

void
writePoseMatrixFile (const std::string& path, const Eigen::Isometry3d& pose)
{
  writeTextAtomic (path, formatMatrix (pose.matrix ()));
}

Trajectory
readTumTrajectory (const std::string& path)
{
  const FileContext context (path);
  std::istringstream in (readTextFile (path));
  Trajectory trajectory;
  std::string line;
  int line_no = 0;
  while (std::getline (in, line))
  {
    ++line_no;
    const std::string where = path + ":" + std::to_string (line_no);
    if (line.find_first_not_of (" \t\r") == std::string::npos || line[line.find_first_not_of (" \t")] == '#')
      continue;
    std::istringstream fields (line);
    double v[8];
    for (double& x : v)
      if (!(fields >> x))
        throw Error (where, "expected 'timestamp tx ty tz qx qy qz qw'");
    Eigen::Quaterniond q (v[7], v[4], v[5], v[6]);
    if (!(std::abs (q.norm () - 1.0) < 1e-2))
      throw Error (where, "quaternion is not unit length");
    StampedPose sp;
    sp.timestamp = v[0];
    sp.pose = Eigen::Isometry3d::Identity ();
    sp.pose.linear () = q.normalized ().toRotationMatrix ();
    sp.pose.translation () = Eigen::Vector3d (v[1], v[2], v[3]);
    if (!trajectory.empty () && !(sp.timestamp > trajectory.back ().timestamp))
      throw Error (where, sp.timestamp == trajectory.back ().timestamp ? "duplicate timestamp" : "timestamps are not sorted");
    trajectory.push_back (sp);
  }
  return trajectory;
}

void
writeTumTrajectory (const std::string& path, const Trajectory& trajectory)
{
  std::ostringstream out;
  out << "# timestamp tx ty tz qx qy qz qw\n" << std::fixed;
  for (const StampedPose& sp : trajectory)
  {
    const Eigen::Quaterniond q (sp.pose.rotation ());
    const Eigen::Vector3d t = sp.pose.translation ();
    out << std::setprecision (6) << sp.timestamp << std::setprecision (9) << " " << t.x () << " " << t.y () << " "
        << t.z () << " " << q.x () << " " << q.y () << " " << q.z () << " " << q.w () << "\n";
  }
  writeTextAtomic (path, out.str ());
}

std::optional<Eigen::Isometry3d>
interpolatePose (const Trajectory& trajectory, double t, double max_gap, double max_extrapolation)
{
  if (trajectory.empty ())
    return std::nullopt;
  const auto after = std::lower_bound (trajectory.begin (), trajectory.end (), t,
                                       [] (const StampedPose& sp, double time) { return sp.timestamp < time; });
  if (after == trajectory.begin ())
  {
    if (after->timestamp - t <= max_extrapolation)
      return after->pose;
    return std::nullopt;
  }
  if (after == trajectory.end ())
  {
    const StampedPose& last = trajectory.back ();
    if (t - last.timestamp <= max_extrapolation)
      return last.pose;
    return std::nullopt;
  }
  const StampedPose& a = *(after - 1);
  const StampedPose& b = *after;
  if (b.timestamp - a.timestamp > max_gap)
    return std::nullopt;
  const double s = (t - a.timestamp) / (b.timestamp - a.timestamp);
  const Eigen::Quaterniond qa (a.pose.rotation ());
  const Eigen::Quaterniond qb (b.pose.rotation ());
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity ();
  pose.linear () = qa.slerp (s, qb).toRotationMatrix ();
  pose.translation () = (1.0 - s) * a.pose.translation () + s * b.pose.translation ();
  return pose;
}

PoseList
readRedwoodLog (const std::string& path)
{
  const FileContext context (path);
  std::istringstream in (readTextFile (path));
  PoseList poses;
  std::string line;
  int line_no = 0;
  auto next_line = [&] (std::string& out) {
    while (std::getline (in, out))
    {
      ++line_no;
      if (out.find_first_not_of (" \t\r") != std::string::npos)
        return true;
    }
    return false;
  };
  while (next_line (line))
  {
    std::istringstream header (line);
    long a, b, c;
    if (!(header >> a >> b >> c))
      throw Error (path + ":" + std::to_string (line_no), "expected a header line 'i j n'");
    Eigen::Matrix4d m;
    for (int r = 0; r < 4; ++r)
    {
      if (!next_line (line))
        throw Error (path + ":" + std::to_string (line_no), "file ends inside a 4x4 matrix");
      std::istringstream row (line);
      std::string extra;
      if (!(row >> m (r, 0) >> m (r, 1) >> m (r, 2) >> m (r, 3)) || (row >> extra))
        throw Error (path + ":" + std::to_string (line_no), "expected 4 numbers in a matrix row");
    }
    poses.push_back (rigidFromMatrix (m, path + ":" + std::to_string (line_no)));
  }
  return poses;
}

void
writeRedwoodLog (const std::string& path, const PoseList& poses)
{
  std::ostringstream out;
  for (std::size_t i = 0; i < poses.size (); ++i)
    out << i << " " << i << " " << i + 1 << "\n" << formatMatrix (poses[i].matrix ());
  writeTextAtomic (path, out.str ());
}
}  // namespace io
}  // namespace cuefusion
