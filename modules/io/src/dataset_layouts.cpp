// SPDX-License-Identifier: BSD-3-Clause
#include <cuefusion/common/exceptions.h>
#include <cuefusion/io/camera_io.h>
#include <cuefusion/io/dataset_layouts.h>
#include <cuefusion/io/file_io.h>
#include <cuefusion/io/pose_io.h>

#include <boost/algorithm/string.hpp>
#include <boost/filesystem.hpp>

#include <pcl/console/print.h>

#include <algorithm>
#include <functional>
#include <cmath>
#include <map>
#include <sstream>

namespace fs = boost::filesystem;

namespace cuefusion
{
namespace io
{
namespace
{
bool
isImageFile (const fs::path& p)
{
  const std::string ext = boost::algorithm::to_lower_copy (p.extension ().string ());
  return ext == ".png" || ext == ".jpg" || ext == ".jpeg";
}

bool
allDigits (const std::string& s)
{
  return !s.empty () && std::all_of (s.begin (), s.end (), [] (char c) { return c >= '0' && c <= '9'; });
}

/** Image files of a folder, in numeric order of their stems when the stems are numbers
  * (ScanNet writes 0.png … 10.png, which sort wrongly as text). */
std::vector<fs::path>
listImages (const fs::path& dir)
{
  std::vector<fs::path> files;
  for (const fs::directory_entry& e : fs::directory_iterator (dir))
    if (fs::is_regular_file (e.path ()) && isImageFile (e.path ()) && e.path ().filename ().string ()[0] != '.')
      files.push_back (e.path ());
  // Numbers compared as digit strings (no conversion: a stem of 30 digits is still a name).
  const auto significant = [] (const std::string& s) {
    const std::size_t first = s.find_first_not_of ('0');
    return first == std::string::npos ? std::string () : s.substr (first);
  };
  std::sort (files.begin (), files.end (), [&] (const fs::path& a, const fs::path& b) {
    const std::string sa = a.stem ().string (), sb = b.stem ().string ();
    if (allDigits (sa) && allDigits (sb) && sa.size () != sb.size ())
    {
      const std::string na = significant (sa), nb = significant (sb);
      if (na.size () != nb.size ())
        return na.size () < nb.size ();
      if (na != nb)
        return na < nb;
    }
    return sa < sb;
  });
  return files;
}

std::string
optionalFile (const fs::path& p)
{
  return fs::is_regular_file (p) ? p.string () : std::string ();
}

/** Same stem in another folder with any image extension ("" when absent). */
std::string
siblingImage (const fs::path& dir, const std::string& stem)
{
  for (const char* ext : {".png", ".jpg", ".jpeg"})
  {
    const fs::path p = dir / (stem + ext);
    if (fs::is_regular_file (p))
      return p.string ();
  }
  return "";
}

/** The frame a file of a Redwood folder belongs to: its stem's number ("000012" and "12"
  * name one frame), or the number before its first '-' (the Redwood scans' "INDEX-STAMP",
  * whose stamps differ between a frame's colour and depth), or else the stem itself. */
std::string
redwoodFrameKey (const std::string& stem)
{
  std::string key = stem;
  const std::size_t dash = stem.find ('-');
  if (dash != std::string::npos && dash > 0 && allDigits (stem.substr (0, dash)))
    key = stem.substr (0, dash);
  if (!key.empty () && allDigits (key))
  {
    const std::size_t first = key.find_first_not_of ('0');
    key = first == std::string::npos ? "0" : key.substr (first);
  }
  return key;
}

void
requireFolder (const fs::path& p, const std::string& what)
{
  if (!fs::is_directory (p))
    throw Error (p.string (), "missing " + what + " folder");
}

PinholeCamera
intrinsicsFrom (const std::string& override_path, const fs::path& default_path)
{
  if (!override_path.empty ())
    return readIntrinsics (override_path);
  if (!fs::is_regular_file (default_path))
    throw Error (default_path.string (), "missing intrinsics file (give one with --intrinsics)");
  return readIntrinsics (default_path.string ());
}

// ---------------------------------------------------------------- TUM
struct StampedFile
{
  double timestamp;
  std::string file;
};

std::vector<StampedFile>
readTumFileList (const fs::path& list)
{
  std::istringstream in (readTextFile (list.string ()));  // names a missing file, a FIFO, a folder
  std::vector<StampedFile> entries;
  std::string line;
  int line_no = 0;
  while (std::getline (in, line))
  {
    ++line_no;
    boost::algorithm::trim (line);
    if (line.empty () || line[0] == '#')
      continue;
    const std::string where = list.string () + ":" + std::to_string (line_no);
    std::istringstream fields (line);
    StampedFile e;
    if (!(fields >> e.timestamp >> e.file))
      throw Error (where, "expected 'timestamp filename'");
    if (!entries.empty () && !(e.timestamp > entries.back ().timestamp))
      throw Error (where, e.timestamp == entries.back ().timestamp ? "duplicate timestamp" : "timestamps are not sorted");
    entries.push_back (e);
  }
  if (entries.empty ())
    throw Error (list.string (), "lists no images");
  return entries;
}

PinholeCamera
tumIntrinsics (const fs::path& root, const std::string& override_path)
{
  if (!override_path.empty ())
    return readIntrinsics (override_path);
  if (fs::is_regular_file (root / "intrinsics.txt"))
    return readIntrinsics ((root / "intrinsics.txt").string ());
  // Published calibration of the benchmark's three Kinects (colour camera; the
  // benchmark's depth images are registered to it).
  const std::string name = fs::absolute (root).filename ().string ();
  if (name.find ("freiburg1") != std::string::npos)
    return {517.3, 516.5, 318.6, 255.3, 0, 0};
  if (name.find ("freiburg2") != std::string::npos)
    return {520.9, 521.0, 325.1, 249.7, 0, 0};
  if (name.find ("freiburg3") != std::string::npos)
    return {535.4, 539.2, 320.1, 247.6, 0, 0};
  PCL_WARN ("[cuefusion] %s: no intrinsics.txt; using the ROS default fx=fy=525 cx=319.5 cy=239.5\n",
            root.string ().c_str ());
  return {525.0, 525.0, 319.5, 239.5, 0, 0};
}
}  // namespace

TumGrabber::TumGrabber (const std::string& root, const Config& config) : DatasetGrabber (root)
{
  const fs::path dir (root);
  depth_units_per_metre_ = 5000.0;
  if (!(config.max_difference > 0.0))
    throw ParameterError ("max difference", "must be positive");
  const std::vector<StampedFile> rgb = readTumFileList (dir / "rgb.txt");
  const std::vector<StampedFile> depth = readTumFileList (dir / "depth.txt");

  // TUM's associate.py: pairs within the tolerance, closest first, each image used once.
  // It weighs every pair within the tolerance, which is quadratic where many stamps fall
  // within it (8,000 stamps in 20 ms: 64 million pairs). Only a stamp's nearest neighbour
  // of the other list on either side can be its closest partner, so those are the
  // candidates here: at most four per image, the same pairs wherever an image's
  // neighbours are not taken by closer pairs (every recorded sequence), and linear.
  struct Pair
  {
    double diff;
    std::size_t rgb, depth;
  };
  std::vector<Pair> candidates;
  const auto neighbours = [&config] (const std::vector<StampedFile>& list, double t, const std::function<void (std::size_t)>& take) {
    const auto it = std::lower_bound (list.begin (), list.end (), t, [] (const StampedFile& d, double v) { return d.timestamp < v; });
    if (it != list.end () && it->timestamp - t <= config.max_difference)
      take (static_cast<std::size_t> (it - list.begin ()));
    if (it != list.begin () && t - std::prev (it)->timestamp <= config.max_difference)
      take (static_cast<std::size_t> (std::prev (it) - list.begin ()));
  };
  for (std::size_t i = 0; i < rgb.size (); ++i)
    neighbours (depth, rgb[i].timestamp, [&] (std::size_t d) { candidates.push_back ({std::abs (depth[d].timestamp - rgb[i].timestamp), i, d}); });
  for (std::size_t d = 0; d < depth.size (); ++d)
    neighbours (rgb, depth[d].timestamp, [&] (std::size_t i) { candidates.push_back ({std::abs (depth[d].timestamp - rgb[i].timestamp), i, d}); });
  std::stable_sort (candidates.begin (), candidates.end (), [] (const Pair& a, const Pair& b) {
    return a.diff < b.diff || (a.diff == b.diff && (a.rgb < b.rgb || (a.rgb == b.rgb && a.depth < b.depth)));
  });
  std::vector<bool> rgb_used (rgb.size (), false), depth_used (depth.size (), false);
  std::map<std::size_t, std::size_t> matches;  // rgb index → depth index, ordered by time
  for (const Pair& p : candidates)
    if (!rgb_used[p.rgb] && !depth_used[p.depth])
    {
      rgb_used[p.rgb] = depth_used[p.depth] = true;
      matches[p.rgb] = p.depth;
    }
  if (matches.empty ())
    throw Error (root, "no colour and depth images within " + std::to_string (config.max_difference) +
                           " s of each other (rgb.txt vs depth.txt)");

  Trajectory groundtruth;
  const fs::path gt_path = dir / "groundtruth.txt";
  if (fs::is_regular_file (gt_path))
    groundtruth = readTumTrajectory (gt_path.string ());

  for (const auto& [ri, di] : matches)
  {
    FrameRecord r;
    r.timestamp = rgb[ri].timestamp;
    r.color_path = (dir / rgb[ri].file).string ();
    r.depth_path = (dir / depth[di].file).string ();
    r.name = fs::path (rgb[ri].file).stem ().string ();
    if (!groundtruth.empty ())
    {
      r.pose = interpolatePose (groundtruth, r.timestamp);
      r.pose_source = gt_path.string ();
    }
    r.instance_path = optionalFile (dir / "instance" / (r.name + ".png"));
    r.class_path = optionalFile (dir / "label" / (r.name + ".png"));
    records_.push_back (r);
  }
  camera_ = tumIntrinsics (dir, config.intrinsics_path);
  finishSetup ();
}

RedwoodGrabber::RedwoodGrabber (const std::string& root, const Config& config) : DatasetGrabber (root)
{
  const fs::path dir (root);
  depth_units_per_metre_ = 1000.0;
  requireFolder (dir / "depth", "depth/");
  fs::path color_dir = dir / "image";
  if (!fs::is_directory (color_dir))
    color_dir = dir / "color";
  requireFolder (color_dir, "image/ or color/");
  const std::vector<fs::path> depth = listImages (dir / "depth");
  const std::vector<fs::path> color = listImages (color_dir);
  // Colour and depth are paired by frame (redwoodFrameKey), never by sort position: a
  // missing or extra file would shift every later pair.
  std::map<std::string, fs::path> color_of_frame;
  for (const fs::path& c : color)
  {
    const auto [it, added] = color_of_frame.emplace (redwoodFrameKey (c.stem ().string ()), c);
    if (!added)
      throw Error (c.string (), "names the same frame as " + it->second.filename ().string ());
  }
  if (depth.size () != color.size ())
    throw Error (root, std::to_string (depth.size ()) + " depth images but " + std::to_string (color.size ()) +
                           " colour images in " + color_dir.filename ().string () + "/");
  PoseList poses;
  const fs::path log = dir / "trajectory.log";
  if (fs::is_regular_file (log))
  {
    poses = readRedwoodLog (log.string ());
    if (poses.size () != depth.size ())
      throw Error (log.string (), "has " + std::to_string (poses.size ()) + " poses for " +
                                      std::to_string (depth.size ()) + " frames");
  }
  for (std::size_t i = 0; i < depth.size (); ++i)
  {
    FrameRecord r;
    r.timestamp = i / config.fps;
    r.name = depth[i].stem ().string ();
    r.depth_path = depth[i].string ();
    const auto c = color_of_frame.find (redwoodFrameKey (r.name));
    if (c == color_of_frame.end ())
      throw Error (r.depth_path, "no colour image of its frame in " + color_dir.filename ().string () +
                                     "/ (a frame's images share a name, or the number before '-')");
    r.color_path = c->second.string ();
    if (!poses.empty ())
    {
      r.pose = poses[i];
      r.pose_source = log.string ();
    }
    r.instance_path = siblingImage (dir / "instance", r.name);
    r.class_path = siblingImage (dir / "label", r.name);
    records_.push_back (r);
  }
  // Redwood and ICL-NUIM as Open3D ships them name it camera_intrinsics.json; Open3D's
  // RealSense recorder writes camera_intrinsic.json and its Azure Kinect recorder
  // intrinsic.json (the same JSON). The first that exists is read.
  fs::path intrinsics = dir / "camera_intrinsics.json";
  for (const char* name : {"camera_intrinsic.json", "intrinsic.json"})
    if (!fs::is_regular_file (intrinsics) && fs::is_regular_file (dir / name))
      intrinsics = dir / name;
  if (config.intrinsics_path.empty () && !fs::is_regular_file (intrinsics))
    throw Error (intrinsics.string (), "missing intrinsics file (or camera_intrinsic.json / intrinsic.json of Open3D's "
                                       "recorders; give one with --intrinsics)");
  camera_ = intrinsicsFrom (config.intrinsics_path, intrinsics);
  finishSetup ();
}

SevenScenesGrabber::SevenScenesGrabber (const std::string& root, const Config& config) : DatasetGrabber (root)
{
  const fs::path dir (root);
  depth_units_per_metre_ = 1000.0;
  std::vector<fs::path> depth;
  for (const fs::directory_entry& e : fs::directory_iterator (dir))
  {
    const std::string name = e.path ().filename ().string ();
    if (boost::algorithm::starts_with (name, "frame-") && boost::algorithm::ends_with (name, ".depth.png"))
      depth.push_back (e.path ());
  }
  std::sort (depth.begin (), depth.end ());
  for (std::size_t i = 0; i < depth.size (); ++i)
  {
    FrameRecord r;
    const std::string file = depth[i].filename ().string ();
    r.name = file.substr (0, file.size () - std::string (".depth.png").size ());
    r.timestamp = i / config.fps;
    r.depth_path = depth[i].string ();
    for (const char* ext : {".color.png", ".color.jpg"})
      if (fs::is_regular_file (dir / (r.name + ext)))
        r.color_path = (dir / (r.name + ext)).string ();
    if (r.color_path.empty ())
      throw Error ((dir / (r.name + ".color.png")).string (), "missing colour image for " + file);
    r.pose_path = optionalFile (dir / (r.name + ".pose.txt"));
    r.pose_source = r.pose_path;
    r.instance_path = optionalFile (dir / (r.name + ".instance.png"));
    r.class_path = optionalFile (dir / (r.name + ".label.png"));
    records_.push_back (r);
  }
  camera_ = intrinsicsFrom (config.intrinsics_path, dir / "camera-intrinsics.txt");
  finishSetup ();
}

ScanNetGrabber::ScanNetGrabber (const std::string& root, const Config& config) : DatasetGrabber (root)
{
  const fs::path dir (root);
  depth_units_per_metre_ = 1000.0;
  requireFolder (dir / "depth", "depth/");
  requireFolder (dir / "color", "color/");
  for (const fs::path& d : listImages (dir / "depth"))
  {
    FrameRecord r;
    r.name = d.stem ().string ();
    if (!allDigits (r.name) || r.name.size () > 15)
      throw Error (d.string (), "ScanNet frames are named by a number of at most 15 digits (e.g. depth/12.png)");
    r.timestamp = std::stoull (r.name) / config.fps;
    r.depth_path = d.string ();
    r.color_path = siblingImage (dir / "color", r.name);
    if (r.color_path.empty ())
      throw Error ((dir / "color" / (r.name + ".jpg")).string (), "missing colour image for " + d.string ());
    r.pose_path = optionalFile (dir / "pose" / (r.name + ".txt"));
    r.pose_source = r.pose_path;
    r.instance_path = optionalFile (dir / "instance-filt" / (r.name + ".png"));
    r.class_path = optionalFile (dir / "label-filt" / (r.name + ".png"));
    records_.push_back (r);
  }
  camera_ = intrinsicsFrom (config.intrinsics_path, dir / "intrinsic" / "intrinsic_depth.txt");
  const fs::path color_intrinsics = dir / "intrinsic" / "intrinsic_color.txt";
  if (fs::is_regular_file (color_intrinsics))
    color_camera_ = readIntrinsics (color_intrinsics.string ());
  finishSetup ();
}
}  // namespace io
}  // namespace cuefusion
