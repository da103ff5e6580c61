// SPDX-License-Identifier: BSD-3-Clause
#include "cli.h"
#include "option_fields.h"

#include <cuefusion/common/exceptions.h>
#include <cuefusion/common/progress.h>
#include <cuefusion/simulation/random_room.h>
#include <cuefusion/simulation/random_scene.h>
#include <cuefusion/simulation/synthetic_sequence.h>

#include <iostream>
#include <sstream>

namespace cuefusion
{
namespace cli
{
namespace
{
void
parseSize (const std::string& size, int& width, int& height)
{
  char x = 0;
  std::istringstream in (size);
  if (!(in >> width >> x >> height) || x != 'x' || !in.eof () || width < 16 || height < 16 || width > 8192 || height > 8192)
    throw ParameterError ("--size", "expected WIDTHxHEIGHT between 16x16 and 8192x8192, e.g. 320x240");
}
}  // namespace

int
runSynth (const std::vector<std::string>& args)
{
  std::string scene_name, room, layout_name, out, size;
  simulation::SyntheticSequenceConfig config;
  long long frames = 0;  // signed: "-5" must not wrap to 2^64 - 5
  std::string sensor = "kinect";
  simulation::DetectorErrorConfig& det = config.detector;
  po::options_description options ("options");
  options.add_options ()
    ("scene", po::value (&scene_name), "scene NAME (data/scenes/NAME.scene) or scene FILE")
    ("room", po::value (&room), "instead of --scene: a random room of this kind (kitchen, office, living) drawn from --seed, "
     "seen along a hand-held path from 1-4 m")
    ("print-scene", "print the scene file (of --scene or --room) and stop")
    (boundOption ("SyntheticSequenceConfig::frames"), po::value (&frames)->default_value (static_cast<long long> (config.frames)), "number of frames")
    ("layout", po::value (&layout_name)->default_value ("tum"), "dataset layout: tum, scannet, redwood, 7scenes")
    ("out", po::value (&out), "output folder (must not exist or be empty)")
    ("seed", po::value (&config.seed)->default_value (config.seed), "seed of every random choice")
    ("size", po::value (&size), "image size WxH (default: the scene's camera), e.g. 320x240")
    (boundOption ("SyntheticSequenceConfig::fps"), po::value (&config.fps)->default_value (config.fps), "frame rate of the timestamps")
    ("noise", po::bool_switch (&config.noise.enabled), "add the sensor's depth noise and dropout (--sensor)")
    ("sensor", po::value (&sensor)->default_value (sensor), "with --noise: kinect (structured light: Kinect v1, Asus Xtion) or "
     "realsense (active stereo, D400-like: noise growing with z^2, speckle, edge fattening, holes on dark surfaces)")
    (boundOption ("SyntheticSequenceConfig::gt_cloud_spacing"), po::value (&config.gt_cloud_spacing)->default_value (config.gt_cloud_spacing),
     "point spacing of gt_cloud.pcd (m)")
    ("gt-all-surfaces", "gt_cloud.pcd holds every surface point, not only those some frame measured")
    (boundOption ("DetectorErrorConfig::boundary_px"), po::value (&det.boundary_px)->default_value (det.boundary_px),
     "simulated detector: grow (>0, leaking) or shrink (<0) masks by this many pixels")
    (boundOption ("DetectorErrorConfig::boundary_jitter_px"), po::value (&det.boundary_jitter_px)->default_value (det.boundary_jitter_px),
     "simulated detector: random extra boundary change per mask and frame, in [-J, J] pixels")
    (boundOption ("DetectorErrorConfig::merge_probability"), po::value (&det.merge_probability)->default_value (det.merge_probability),
     "simulated detector: probability per frame that two touching objects come out as one mask")
    (boundOption ("DetectorErrorConfig::split_probability"), po::value (&det.split_probability)->default_value (det.split_probability),
     "simulated detector: probability per mask and frame that it comes out as two masks")
    (boundOption ("DetectorErrorConfig::miss_probability"), po::value (&det.miss_probability)->default_value (det.miss_probability),
     "simulated detector: probability per object and frame of missing it")
    (boundOption ("DetectorErrorConfig::false_positives"), po::value (&det.false_positives)->default_value (det.false_positives),
     "simulated detector: mean number of spurious masks per frame")
    (boundOption ("DetectorErrorConfig::min_pixels"), po::value (&det.min_pixels)->default_value (det.min_pixels),
     "simulated detector: never report objects with fewer visible pixels")
    ("overwrite", "replace OUT if it exists");
  po::positional_options_description positional;
  po::variables_map vm;
  if (!parseCommandLine ("synth", "--scene NAME|FILE|--room TYPE --out DIR [options]", args, options, positional, vm))
    return 0;
  if (scene_name.empty () == room.empty ())
    throw UsageError ("give one of --scene and --room");
  if (out.empty () && !vm.count ("print-scene"))
    throw UsageError ("the option '--out' is required but missing");
  if (frames < 1 || frames > 1000000)
    throw ParameterError ("--frames", "must lie in [1, 1000000], got " + std::to_string (frames));
  config.frames = static_cast<std::size_t> (frames);
  config.gt_observed_only = vm.count ("gt-all-surfaces") == 0;
  if (sensor == "kinect" || sensor == "realsense")
    config.noise.sensor = sensor == "kinect" ? simulation::DepthSensor::Kinect : simulation::DepthSensor::RealSense;
  else
    throw ParameterError ("--sensor", "must be kinect or realsense, not '" + sensor + "'");
  if (given (vm, "sensor") && !config.noise.enabled)
    throw UsageError ("--sensor needs --noise");
  if (!size.empty ())
    parseSize (size, config.width, config.height);
  const io::DatasetLayout layout = io::parseDatasetLayout (layout_name);
  config.validate ();
  simulation::RoomConfig room_config;
  if (!room.empty ())
    room_config.type = simulation::parseRoomType (room, "--room");
  const simulation::SyntheticScene scene = room.empty () ? simulation::SyntheticScene::load (simulation::resolveScenePath (scene_name, simulation::defaultScenesDir ()))
                                                 : simulation::generateRoom (room_config, config.seed);
  if (vm.count ("print-scene"))
  {
    std::cout << scene.text ();
    return 0;
  }
  const simulation::SyntheticSequence sequence (scene, config);

  ProgressReporter progress ("synth", sequence.size ());
  simulation::writeSyntheticSequence (sequence, layout, out, vm.count ("overwrite") > 0,
                              [&progress] (std::size_t done) { progress.update (done); });
  progress.finish ();
  const PinholeCamera& c = sequence.camera ();
  std::cout << "wrote " << sequence.size () << " frames of scene '" << scene.name << "' (" << c.width << "x" << c.height
            << ", " << scene.objects.size () << " objects) as " << layout_name << " to " << out << "\n";
  return 0;
}

int
runSynthViews (const std::vector<std::string>& args)
{
  std::string out, size = "320x240";
  std::size_t views = 0;
  std::uint64_t seed = 1;
  simulation::RandomSceneConfig config;
  po::options_description options ("options");
  options.add_options ()
    ("views", po::value (&views)->required (), "number of views to render")
    ("out", po::value (&out)->required (), "output folder (must not exist or be empty)")
    ("seed", po::value (&seed)->default_value (seed), "seed of every random choice (view i depends only on seed and i)")
    ("size", po::value (&size)->default_value (size), "image size WxH")
    (boundOption ("RandomSceneConfig::views_per_scene"), po::value (&config.views_per_scene)->default_value (config.views_per_scene), "camera poses per random scene")
    ("min-objects", po::value (&config.min_objects)->default_value (config.min_objects), "fewest objects in a scene")
    ("max-objects", po::value (&config.max_objects)->default_value (config.max_objects), "most objects in a scene")
    (boundOption ("RandomSceneConfig::touching_probability"), po::value (&config.touching_probability)->default_value (config.touching_probability),
     "probability that an object is placed against another")
    (boundOption ("RandomSceneConfig::stacking_probability"), po::value (&config.stacking_probability)->default_value (config.stacking_probability),
     "probability that a box, can or ball is put on a box")
    (boundOption ("RandomSceneConfig::multipart_probability"), po::value (&config.multipart_probability)->default_value (config.multipart_probability),
     "probability of a multi-part object (bottle, L-block, snowman, mug)")
    (boundOption ("RandomSceneConfig::figure_probability"), po::value (&config.figure_probability)->default_value (config.figure_probability),
     "share of the multi-part objects drawn as figures (a soft toy: body, head, arms, ears, legs)")
    (boundOption ("RandomSceneConfig::aligned_probability"), po::value (&config.aligned_probability)->default_value (config.aligned_probability),
     "share of the boxes placed flush against a box that are lined up with it (one side face in one plane)")
    (boundOption ("RandomSceneConfig::room_probability"), po::value (&config.room_probability)->default_value (config.room_probability),
     "share of the scenes drawn as a random kitchen, office or living room seen from its camera path (objects up to twice the largest table-top object)")
    (boundOption ("RandomSceneConfig::table_probability"), po::value (&config.table_probability)->default_value (config.table_probability),
     "probability that the objects stand on a table (else on the floor)")
    ("overwrite", "replace OUT if it exists");
  po::positional_options_description positional;
  po::variables_map vm;
  if (!parseCommandLine ("synth-views", "--views N --out DIR [options]", args, options, positional, vm))
    return 0;
  int width = 0, height = 0;
  parseSize (size, width, height);
  if (views < 1 || views > 10000000)
    throw ParameterError ("--views", "must lie in [1, 10000000]");
  const simulation::RandomSceneGenerator generator (config, seed);
  ProgressReporter progress ("synth-views", views);
  simulation::writeRandomViews (generator, views, width, height, out, vm.count ("overwrite") > 0,
                        [&progress] (std::size_t done) { progress.update (done); });
  progress.finish ();
  std::cout << "wrote " << views << " random views (" << width << "x" << height << ", seed " << seed << ") to " << out << "\n";
  return 0;
}
}  // namespace cli
}  // namespace cuefusion
