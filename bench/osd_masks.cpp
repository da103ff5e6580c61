// SPDX-License-Identifier: BSD-3-Clause
// Instance masks for the OSD clouds, derived from their ground truth with the synthetic
// generator's detector error model (SimulatedDetector: dilation, jitter, merges of
// touching objects, misses), so that scripts/bench can score geometry-only, masks-only
// and fused segmentation on real depth with network-like masks.
// Usage: cuefusion_bench_osd_masks GT_DIR OUT_DIR [--dilate PX] [--jitter PX] [--merge P] [--miss P] [--split P] [--false-positives N] [--seed N]
// Writes OUT_DIR/<stem>.png (16-bit instance ids) and <stem>.json per GT cloud.
#include <cuefusion/io/file_io.h>
#include <cuefusion/simulation/simulated_detector.h>

#include <boost/filesystem.hpp>

#include <pcl/io/pcd_io.h>

#include <algorithm>
#include <iostream>
#include <map>
#include <string>

namespace fs = boost::filesystem;
using namespace cuefusion;

int
main (int argc, char** argv)
{
  if (argc < 3)
  {
    std::cerr << "usage: cuefusion_bench_osd_masks GT_DIR OUT_DIR [--dilate PX] [--jitter PX] [--merge P] [--miss P] [--split P] [--false-positives N] [--seed N]\n";
    return 2;
  }
  simulation::DetectorErrorConfig errors;
  errors.boundary_px = 2;
  errors.boundary_jitter_px = 1;
  errors.merge_probability = 0.2;
  errors.miss_probability = 0.1;
  std::uint64_t seed = 1;
  for (int i = 3; i + 1 < argc; i += 2)
  {
    const std::string option = argv[i];
    const double value = std::stod (argv[i + 1]);
    if (option == "--dilate")
      errors.boundary_px = static_cast<int> (value);
    else if (option == "--jitter")
      errors.boundary_jitter_px = static_cast<int> (value);
    else if (option == "--merge")
      errors.merge_probability = value;
    else if (option == "--miss")
      errors.miss_probability = value;
    else if (option == "--split")
      errors.split_probability = value;
    else if (option == "--false-positives")
      errors.false_positives = value;
    else if (option == "--seed")
      seed = static_cast<std::uint64_t> (value);
    else
    {
      std::cerr << "cuefusion_bench_osd_masks: unknown option " << option << "\n";
      return 2;
    }
  }
  errors.validate ();
  std::vector<fs::path> inputs;
  for (fs::directory_iterator it (argv[1]), end; it != end; ++it)
    if (it->path ().extension () == ".pcd")
      inputs.push_back (it->path ());
  std::sort (inputs.begin (), inputs.end ());
  fs::create_directories (argv[2]);
  pcl::console::setVerbosityLevel (pcl::console::L_ALWAYS);
  for (std::size_t f = 0; f < inputs.size (); ++f)
  {
    pcl::PointCloud<pcl::PointXYZL> gt;
    if (pcl::io::loadPCDFile (inputs[f].string (), gt) < 0 || !gt.isOrganized ())
    {
      std::cerr << inputs[f].string () << ": cannot read an organized labelled PCD\n";
      return 1;
    }
    // mOSD labels: >= 20 object parts, object = label / 10 (the scoring protocol's objects).
    cv::Mat truth (static_cast<int> (gt.height), static_cast<int> (gt.width), CV_16U, cv::Scalar (0));
    std::map<std::uint32_t, std::uint16_t> ids;
    for (int y = 0; y < truth.rows; ++y)
      for (int x = 0; x < truth.cols; ++x)
      {
        const auto& p = gt (x, y);
        if (p.label < 20 || !std::isfinite (p.z))
          continue;
        const auto it = ids.emplace (p.label / 10, static_cast<std::uint16_t> (ids.size () + 1)).first;
        truth.at<std::uint16_t> (y, x) = it->second;
      }
    simulation::SyntheticScene scene;  // one detectable "object" per GT object, for the detector
    for (std::size_t i = 0; i < ids.size (); ++i)
    {
      simulation::SceneObject object;
      object.id = static_cast<std::uint16_t> (i + 1);
      object.name = "object" + std::to_string (i + 1);
      object.class_name = "object";
      scene.objects.push_back (object);
    }
    const simulation::DetectionResult result = simulation::SimulatedDetector (scene, errors, seed).detect (truth, f);
    const std::string stem = (fs::path (argv[2]) / inputs[f].stem ()).string ();
    io::writeImageAtomic (stem + ".png", result.ids);
    io::writeTextAtomic (stem + ".json", simulation::detectionsToJson (result));
  }
  return 0;
}
