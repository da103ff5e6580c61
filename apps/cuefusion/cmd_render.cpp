// SPDX-License-Identifier: BSD-3-Clause
// cuefusion render: the labelled mesh of a run from N viewpoints around it or from its own
// camera poses, as PNGs, with no display (the project's own rasterizer).
#include "cli.h"

#include <cuefusion/common/exceptions.h>
#include <cuefusion/io/file_io.h>
#include <cuefusion/io/mesh_io.h>
#include <cuefusion/io/pose_io.h>
#include <cuefusion/segmentation/segments_file.h>
#include <cuefusion/visualization/mesh_pieces.h>
#include <cuefusion/visualization/mesh_rasterizer.h>

#include <boost/filesystem.hpp>

#include <iomanip>
#include <iostream>
#include <set>
#include <sstream>

namespace fs = boost::filesystem;

namespace cuefusion
{
namespace cli
{
int
runRender (const std::vector<std::string>& args)
{
  std::string run_dir, out, size = "1280x960", color = "segments", frame = "objects", from = "orbit";
  int views = 8, min_piece = 100;
  po::options_description options ("options");
  options.add_options ()
    ("run", po::value (&run_dir)->required (), "output folder of `cuefusion run` (reads mesh.ply)")
    ("views", po::value (&views)->default_value (views), "number of viewpoints")
    ("from", po::value (&from)->default_value (from), "where the views are: 'orbit' (on a circle around the map, 30° above it, looking in) or 'cameras' (the run's own camera poses from trajectory.txt, evenly spaced along it: a room from inside)")
    ("out", po::value (&out), "folder for view_NN.png (default RUN/renders)")
    ("size", po::value (&size)->default_value (size), "image size WxH")
    ("color", po::value (&color)->default_value (color), "'segments' (fixed palette per label) or 'rgb' (fused colour)")
    ("min-piece", po::value (&min_piece)->default_value (min_piece), "leave out connected pieces of the mesh with fewer triangles than this: the specks of surfaces seen a few times from far away (0 draws every piece)")
    ("frame", po::value (&frame)->default_value (frame), "what the orbit's views frame: 'objects' (the segments segments.json gives a class; the whole map when none has one) or 'map' (every labelled surface, a room's floor and walls too)");
  po::positional_options_description positional;
  po::variables_map vm;
  if (!parseCommandLine ("render", "--run DIR [--views N] [options]", args, options, positional, vm))
    return 0;
  if (views < 1 || views > 360)
    throw ParameterError ("--views", "must lie in [1, 360]");
  if (min_piece < 0)
    throw ParameterError ("--min-piece", "must be at least 0");
  int width = 0, height = 0;
  char x = 0;
  std::istringstream dims (size);
  if (!(dims >> width >> x >> height) || x != 'x' || width < 16 || height < 16 || width > 8192 || height > 8192)
    throw ParameterError ("--size", "must be WxH with sides in [16, 8192], not '" + size + "'");
  if (color != "segments" && color != "rgb")
    throw ParameterError ("--color", "must be 'segments' or 'rgb', not '" + color + "'");
  if (frame != "objects" && frame != "map")
    throw ParameterError ("--frame", "must be 'objects' or 'map', not '" + frame + "'");
  if (from != "orbit" && from != "cameras")
    throw ParameterError ("--from", "must be 'orbit' or 'cameras', not '" + from + "'");
  if (out.empty ())
    out = (fs::path (run_dir) / "renders").string ();

  const io::TriangleMesh read = io::readMeshPLY ((fs::path (run_dir) / "mesh.ply").string ());
  if (read.triangles.empty ())
    throw Error ((fs::path (run_dir) / "mesh.ply").string (), "mesh has no triangles");
  const io::TriangleMesh mesh = visualization::withoutSmallPieces (read, static_cast<std::size_t> (min_piece));

  // A virtual camera with a 60° horizontal field of view.
  const double f = 0.5 * width / std::tan (30.0 * M_PI / 180.0);
  const PinholeCamera camera (f, f, 0.5 * (width - 1), 0.5 * (height - 1), width, height);
  visualization::MeshRasterizerConfig config;
  config.color_by_label = color == "segments";
  config.cull_back_faces = true;  // see into rooms through the walls that face away
  const visualization::MeshRasterizer rasterizer (config);
  // Up is where the run's cameras had it (datasets differ: z-up, y-up).
  std::vector<Eigen::Isometry3d, Eigen::aligned_allocator<Eigen::Isometry3d>> cameras;
  const fs::path trajectory = fs::path (run_dir) / "trajectory.txt";
  if (from == "cameras" && !fs::exists (trajectory))
    throw Error (trajectory.string (), "not found: --from cameras renders from the run's camera poses");
  if (fs::exists (trajectory))
    for (const io::StampedPose& p : io::readTumTrajectory (trajectory.string ()))
      cameras.push_back (p.pose);
  if (from == "cameras" && cameras.empty ())
    throw Error (trajectory.string (), "holds no pose: --from cameras renders from the run's camera poses");
  // The objects, not a room's floor and walls, set the orbit's framing: the segments the masks gave a class.
  std::set<std::uint32_t> objects;
  const fs::path segments = fs::path (run_dir) / "segments.json";
  if (from == "orbit" && frame == "objects" && fs::exists (segments))
    for (const segmentation::SegmentEntry& entry : segmentation::readSegmentsJson (segments.string ()))
      if (!entry.class_name.empty ())
        objects.insert (entry.id);
  const auto poses = from == "cameras" ? visualization::cameraViews (cameras, views)
                                       : visualization::orbitViews (mesh, camera, views, visualization::upFromCameras (cameras), objects);
  // Every input read and checked before anything is written.
  boost::system::error_code ec;
  fs::create_directories (out, ec);
  if (ec || !fs::is_directory (out))
    throw Error (out, "cannot create folder" + (ec ? ": " + ec.message () : std::string ()));
  for (int k = 0; k < views; ++k)
  {
    std::ostringstream name;
    name << "view_" << std::setw (2) << std::setfill ('0') << k << ".png";
    const visualization::MeshView view = rasterizer.render (mesh, camera, poses[static_cast<std::size_t> (k)]);
    io::writeImageAtomic ((fs::path (out) / name.str ()).string (), view.image);
  }
  std::cout << "rendered " << views << " view(s) of " << (fs::path (run_dir) / "mesh.ply").string () << " (" << mesh.triangles.size ()
            << " triangles; "
            << (from == "cameras" ? std::string ("from the run's cameras")
                                  : "framing " + (objects.empty () ? std::string ("the map") : std::to_string (objects.size ()) + " object(s)"))
            << ") to "
            << out << "\n";
  return 0;
}
}  // namespace cli
}  // namespace cuefusion
