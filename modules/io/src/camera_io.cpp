// SPDX-License-Identifier: BSD-3-Clause
#include <cuefusion/common/exceptions.h>
#include <cuefusion/io/camera_io.h>
#include <cuefusion/io/file_io.h>

#include <boost/algorithm/string/predicate.hpp>
#include <nlohmann/json.hpp>

#include <cmath>
#include <iomanip>
#include <sstream>

namespace cuefusion
{
namespace io
{
namespace
{
PinholeCamera
readIntrinsicsJson (const std::string& path)
{
  nlohmann::json j = readJsonFile (path);
  if (!j.is_object () || !j.contains ("intrinsic_matrix") || !j["intrinsic_matrix"].is_array () ||
      j["intrinsic_matrix"].size () != 9)
    throw Error (path, "expected an object with \"intrinsic_matrix\" of 9 numbers (Open3D layout)");
  std::vector<double> k;
  try
  {
    k = j["intrinsic_matrix"].get<std::vector<double>> ();
  }
  catch (const nlohmann::json::exception&)
  {
    throw Error (path, "\"intrinsic_matrix\" must hold numbers");
  }
  // Open3D stores K column-major: [fx 0 0, 0 fy 0, cx cy 1].
  PinholeCamera camera (k[0], k[4], k[6], k[7], 0, 0);
  for (const auto& [key, target] : {std::make_pair ("width", &camera.width), std::make_pair ("height", &camera.height)})
  {
    if (!j.contains (key))
      continue;
    // Read wide: an int read of 4294967616 would silently become 320.
    if (!j[key].is_number_integer () || j[key].get<long long> () < 1 || j[key].get<long long> () > 65536)
      throw Error (path, std::string ("\"") + key + "\" must be an integer in [1, 65536], found " + jsonText (j[key]));
    *target = static_cast<int> (j[key].get<long long> ());
  }
  return camera;
}
}  // namespace

PinholeCamera
readIntrinsics (const std::string& path)
{
  const FileContext context (path);
  PinholeCamera camera;
  if (boost::algorithm::iends_with (path, ".json"))
    camera = readIntrinsicsJson (path);
  else
  {
    const std::vector<double> n = readNumbers (path);
    if (n.size () == 9 || n.size () == 16)
    {
      const int stride = n.size () == 9 ? 3 : 4;
      camera = PinholeCamera (n[0], n[stride + 1], n[2], n[stride + 2], 0, 0);
    }
    else if (n.size () == 4 || n.size () == 6)
    {
      camera = PinholeCamera (n[0], n[1], n[2], n[3], 0, 0);
      if (n.size () == 6)
      {
        if (n[4] != std::floor (n[4]) || n[5] != std::floor (n[5]) || !(n[4] >= 1 && n[4] <= 65536) || !(n[5] >= 1 && n[5] <= 65536))
          throw Error (path, "image width and height must be integers in [1, 65536]");
        camera.width = static_cast<int> (n[4]);
        camera.height = static_cast<int> (n[5]);
      }
    }
    else
      throw Error (path, "expected a 3x3 or 4x4 intrinsic matrix or 'fx fy cx cy [width height]', found " +
                             std::to_string (n.size ()) + " numbers");
  }
  PinholeCamera check = camera;
  if (check.width == 0 && check.height == 0)
    check.width = check.height = 65536;  // size comes later from the images (checked again then)
  check.validate (path);
  return camera;
}

void
writeIntrinsicsJson (const std::string& path, const PinholeCamera& c)
{
  nlohmann::json j;
  j["width"] = c.width;
  j["height"] = c.height;
  j["intrinsic_matrix"] = {c.fx, 0.0, 0.0, 0.0, c.fy, 0.0, c.cx, c.cy, 1.0};
  writeTextAtomic (path, j.dump (1, '\t', false, nlohmann::json::error_handler_t::replace) + "\n");
}

void
writeIntrinsicsMatrix (const std::string& path, const PinholeCamera& c, int rows)
{
  Eigen::Matrix4d k = Eigen::Matrix4d::Identity ();
  k.topLeftCorner<3, 3> () = c.matrix ();
  std::ostringstream out;
  out << std::setprecision (17);
  for (int r = 0; r < rows; ++r)
  {
    for (int col = 0; col < rows; ++col)
      out << (col ? " " : "") << k (r, col);
    out << "\n";
  }
  writeTextAtomic (path, out.str ());
}

void
writeIntrinsicsLine (const std::string& path, const PinholeCamera& c)
{
  std::ostringstream out;
  out << std::setprecision (17) << c.fx << " " << c.fy << " " << c.cx << " " << c.cy << " " << c.width << " "
      << c.height << "\n";
  writeTextAtomic (path, out.str ());
}
}  // namespace io
}  // namespace cuefusion
