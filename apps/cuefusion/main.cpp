// SPDX-License-Identifier: BSD-3-Clause
// cuefusion: object-level 3D segmentation of RGB-D sequences — command-line front end.
// Exit codes: 0 success, 1 failure (bad input, I/O), 2 bad usage.
#include "cli.h"
#include "commands.h"
#include "plugin.h"

#include <cuefusion/common/data_directory.h>
#include <cuefusion/common/exceptions.h>
#include <cuefusion/io/file_io.h>

#include <pcl/console/print.h>

#include <iostream>
#include <map>

namespace
{
const char* kUsage =
  "usage: cuefusion COMMAND [OPTIONS]\n"
  "\n"
  "commands:\n"
  "  synth   render a synthetic RGB-D sequence with exact ground truth\n"
  "  synth-views\n"
  "          render random scenes with exact instance masks (training data for a segmenter)\n"
  "  info    describe a sequence: format, frames, resolution, intrinsics, poses, masks\n"
  "  run     process a sequence (folder, openni2[:DEVICE] or .oni file) into a map\n"
  "  segment-frame\n"
  "          geometric segmentation of organized clouds or depth images (PCD/PNG, or folders)\n"
  "  eval    score runs against a sequence's truth: ATE/RPE, per-frame object IoU, 3D instance AP\n"
  "  render  draw a run's labelled mesh from N viewpoints to PNG (no display needed)\n"
  "  batch   run (and eval) many sequences through GNU parallel or a Slurm job array, resumable, with a\n"
  "          dataset summary (AP pooled over the sequences)\n"
  "  batch-task\n"
  "          one sequence of a batch (what batch's parallel jobs and Slurm tasks run)\n"
  "\n"
  "'cuefusion COMMAND --help' describes a command's options; 'cuefusion --version' prints the version.\n";
}

int
main (int argc, char** argv)
{
  using namespace cuefusion::cli;
  // The commands of this executable; the others (nullptr) are libcuefusion_commands.so's.
  const std::map<std::string, int (*) (const std::vector<std::string>&)> commands = {
    {"synth", runSynth}, {"synth-views", runSynthViews}, {"info", runInfo}, {"run", nullptr}, {"segment-frame", nullptr},
    {"eval", nullptr},   {"render", nullptr},            {"batch", nullptr},  {"batch-task", nullptr}};
  if (argc < 2)
  {
    std::cerr << kUsage;
    return 2;
  }
  const std::string command = argv[1];
  if (command == "--help" || command == "-h" || command == "help")
  {
    std::cout << kUsage;
    return 0;
  }
  if (command == "--version" || command == "version")
  {
    std::cout << "cuefusion " << cuefusion::version () << "\n";
    return 0;
  }
  const auto it = commands.find (command);
  if (it == commands.end ())
  {
    std::cerr << "cuefusion: unknown command '" << command << "'\n" << kUsage;
    return 2;
  }
  // Errors reach the user as one line from the command (cuefusion::Error); PCL's own
  // console messages would add a second, so they are off.
  pcl::console::setVerbosityLevel (pcl::console::L_ALWAYS);
  try
  {
    int (*run) (const std::vector<std::string>&) = it->second;
    if (!run)
      for (const Command* c = reinterpret_cast<const Command* (*) ()> (pluginSymbol (kCommandsLibrary, kCommandsSymbol)) ();
           c->name; ++c)
        if (command == c->name)
          run = c->run;
    if (!run)
      throw cuefusion::Error (kCommandsLibrary, "has no command '" + command + "'; it is not this cuefusion's");
    return run (std::vector<std::string> (argv + 2, argv + argc));
  }
  catch (const UsageError& e)
  {
    std::cerr << "cuefusion " << command << ": " << e.what () << " (see 'cuefusion " << command << " --help')\n";
    return 2;
  }
  catch (const cuefusion::ParameterError& e)
  {
    // The library names config fields; the user typed options.
    static const std::map<std::string, std::string> options = {
      {"InstanceGuidedRegionMergeConfig::min_overlap", "--min-overlap"},
      {"InstanceGuidedRegionMergeConfig::color_split_distance", "--color-split"},
      {"ConcavityEdgeEstimationConfig::noise_slope", "--concavity-noise-slope"},
      {"ConcavityEdgeEstimationConfig::threshold", "--concavity-threshold"},
      {"ConcavityEdgeEstimationConfig::neighbour_step", "--concavity-step"},
      {"DepthDiscontinuityEdgeEstimationConfig::noise_factor", "--noise-factor"},
      {"GeometricSegmentationConfig::noise_scale", "--noise-scale"},
      {"DepthDiscontinuityEdgeEstimationConfig::neighbour_step", "--depth-edge-step"},
      {"EdgeLabelingConfig::closing_iterations", "--closings"},
      {"EdgeLabelingConfig::min_segment_size", "--min-segment-size"},
      {"EdgeLabelingConfig::edge_assignment_radius", "--edge-radius"},
      {"EdgeLabelingConfig::max_depth_jump", "--max-depth-jump"},
      {"SurfacePreprocessingConfig::normals.step", "--normal-step"},
      {"SurfacePreprocessingConfig::normals.max_depth_jump", "--max-depth-jump"},
      {"SurfacePreprocessingConfig::integral_smoothing", "--normal-smoothing"},
      {"SupportPlaneRemovalConfig::distance_threshold", "--plane-distance"},
      {"SupportPlaneRemovalConfig::max_iterations", "--plane-iterations"},
      {"SupportPlaneRemovalConfig::sample_step", "--plane-sample-step"},
      {"SupportPlaneRemovalConfig::min_plane_fraction", "--min-plane-fraction"},
      {"SupportPlaneRemovalConfig::min_segment_inlier_fraction", "--plane-segment-fraction"},
      {"SupportPlaneRemovalConfig::max_normal_angle_deg", "--plane-normal-angle"},
      {"SurfacePreprocessingConfig::bilateral.noise_range_sigma", "--range-sigma"},
      {"SurfacePreprocessingConfig::bilateral.sigma_space", "--sigma-space"},
      {"SurfacePreprocessingConfig::bilateral.diameter", "--bilateral-diameter"},
      {"OnnxInstanceSegmenterConfig::input_size", "--input-size"},
      {"OnnxInstanceSegmenterConfig::score_threshold", "--score-threshold"},
      {"OnnxInstanceSegmenterConfig::boundary_threshold", "--boundary-threshold"},
      {"RandomSceneConfig::min_objects", "--min-objects/--max-objects"},
      {"RandomSceneConfig::touching_probability", "--touching"},
      {"RandomSceneConfig::stacking_probability", "--stacking"},
      {"RandomSceneConfig::multipart_probability", "--multipart"},
      {"RandomSceneConfig::figure_probability", "--figures"},
      {"RandomSceneConfig::aligned_probability", "--aligned"},
      {"RandomSceneConfig::table_probability", "--table"},
      {"RandomSceneConfig::views_per_scene", "--views-per-scene"},
      {"DetectorErrorConfig::merge_probability", "--mask-merge"},
      {"DetectorErrorConfig::miss_probability", "--mask-miss"},
      {"DetectorErrorConfig::split_probability", "--mask-split"},
      {"DetectorErrorConfig::false_positives", "--mask-false-positives"},
      {"DetectorErrorConfig::boundary_px", "--mask-boundary"},
      {"DetectorErrorConfig::boundary_jitter_px", "--mask-jitter"},
      {"DetectorErrorConfig::min_pixels", "--mask-min-pixels"},
      {"SyntheticSequenceConfig::frames", "--frames"},
      {"SyntheticSequenceConfig::fps", "--fps"},
      {"SyntheticSequenceConfig::width", "--size"},
      {"SyntheticSequenceConfig::gt_cloud_spacing", "--gt-spacing"},
      {"SequenceFormat", "--format"},
      {"DatasetLayout", "--layout"},
      {"SegmentationMode", "--mode"},
      {"TSDFVolumeConfig::voxel_size", "--voxel"},
      {"TSDFVolumeConfig::truncation_voxels", "--truncation"},
      {"TSDFVolumeConfig::max_depth", "--max-depth"},
      {"DepthPreprocessorConfig::max_depth", "--max-depth"},
      {"DenseReconstructionConfig::hole_refresh_period", "--hole-refresh"},
      {"RunEvaluationConfig::every", "--every"},
      {"FrameIoUConfig::min_truth_pixels", "--min-pixels"},
      {"InstanceAPConfig::min_region_size", "--min-region"},
      {"RunEvaluationConfig::match_radius", "--match-radius"},
    };
    const auto option = options.find (e.parameter ());
    std::cerr << "cuefusion " << command << ": "
              << (option == options.end () ? std::string (e.what ()) : option->second + ": " + e.reason ()) << " (see 'cuefusion "
              << command << " --help')\n";
    return 2;
  }
  catch (const cuefusion::Error& e)
  {
    std::cerr << "cuefusion " << command << ": " << cuefusion::io::OutputSet::finalPaths (e.what ()) << "\n";
    return 1;
  }
  catch (const std::exception& e)  // PCL's, the standard library's, out of memory: named by FileContext
  {
    std::cerr << "cuefusion " << command << ": " << cuefusion::io::OutputSet::finalPaths (cuefusion::describeException (e)) << "\n";
    return 1;
  }
}
