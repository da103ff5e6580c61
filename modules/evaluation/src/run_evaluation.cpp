// SPDX-License-Identifier: BSD-3-Clause
// The chapter 5 evaluation of `cuefusion run` output folders against a sequence's truth:
// tracking, per-frame object IoU (the final map rendered at each pose, or the run's own
// labels/), 3D instance AP of map.pcd. `cuefusion eval` and Python's evaluate_run call it.
#include <cuefusion/evaluation/run_evaluation.h>

#include <cuefusion/common/exceptions.h>
#include <cuefusion/io/dataset_grabber.h>
#include <cuefusion/io/file_io.h>
#include <cuefusion/io/map_io.h>
#include <cuefusion/pipeline/run_files.h>
#include <cuefusion/segmentation/segments_file.h>
#include <cuefusion/visualization/mesh_rasterizer.h>

#include <boost/filesystem.hpp>
#include <pcl/conversions.h>
#include <pcl/kdtree/kdtree_flann.h>

#include <cmath>
#include <iomanip>
#include <sstream>

namespace fs = boost::filesystem;

namespace cuefusion
{
namespace evaluation
{
namespace
{
/** Poses are matched to frames by their timestamps in whole microseconds. */
long long
microseconds (double t)
{
  return std::llround (t * 1e6);
}

/** The sequence's reference trajectory from its index (poses in the listing or per-frame files). */
io::Trajectory
referenceTrajectory (const io::DatasetGrabber& dataset)
{
  io::Trajectory reference;
  for (const io::FrameRecord& r : dataset.records ())
  {
    if (r.pose)
      reference.push_back ({r.timestamp, *r.pose});
    else if (!r.pose_path.empty ())
      if (const auto pose = io::readPoseMatrixFile (r.pose_path))
        reference.push_back ({r.timestamp, *pose});
  }
  return reference;
}

/** Ground-truth points take the segment of the nearest map point within \a radius. */
std::vector<std::uint32_t>
transferLabels (const pcl::PointCloud<pcl::PointXYZL>& truth, const pcl::PointCloud<pcl::PointXYZL>::Ptr& map, double radius)
{
  std::vector<std::uint32_t> labels (truth.size (), 0);
  if (map->empty ())
    return labels;
  pcl::KdTreeFLANN<pcl::PointXYZL> tree;
  tree.setInputCloud (map);
  std::vector<int> index (1);
  std::vector<float> distance (1);
  const float r2 = static_cast<float> (radius * radius);
  for (std::size_t i = 0; i < truth.size (); ++i)
    if (tree.nearestKSearch (truth[i], 1, index, distance) == 1 && distance[0] <= r2)
      labels[i] = (*map)[static_cast<std::size_t> (index[0])].label;
  return labels;
}

std::optional<TrackingEvaluation>
evaluateTracking (const io::Trajectory& estimate, const io::Trajectory& reference, double max_time_difference)
{
  if (associatePoses (estimate, reference, max_time_difference).size () < 3)
    return std::nullopt;
  TrackingEvaluation tracking;
  tracking.ate = absoluteTrajectoryError (estimate, reference, max_time_difference);
  const auto rpe = [&] (RelativePoseInterval::Unit unit) -> std::optional<RelativePoseError> {
    try
    {
      return relativePoseError (estimate, reference, RelativePoseInterval{unit, 1.0}, max_time_difference);
    }
    catch (const Error&)
    {
      return std::nullopt;  // the sequence is shorter than the interval
    }
  };
  tracking.rpe_frame = rpe (RelativePoseInterval::Unit::Frames);
  tracking.rpe_second = rpe (RelativePoseInterval::Unit::Seconds);
  return tracking;
}

/** The frame's objects: its instance mask without the stuff instances. */
cv::Mat
objectMask (const RGBDFrame& frame, const std::set<std::uint32_t>& stuff)
{
  cv::Mat objects = frame.instance_mask.clone ();
  for (int r = 0; r < objects.rows; ++r)
    for (int c = 0; c < objects.cols; ++c)
      if (stuff.count (objects.at<std::uint16_t> (r, c)))
        objects.at<std::uint16_t> (r, c) = 0;
  return objects;
}

/** Where the frame measured depth (only those pixels are scored). */
cv::Mat
measuredPixels (const RGBDFrame& frame)
{
  cv::Mat valid (frame.depth.size (), CV_8U);
  for (int r = 0; r < valid.rows; ++r)
    for (int c = 0; c < valid.cols; ++c)
      valid.at<std::uint8_t> (r, c) = isValidDepth (frame.depth.at<float> (r, c)) ? 255 : 0;
  return valid;
}

/** The labels a run shows in one frame of the sequence: the final map rendered at the
  * run's pose, or its labels/ image; empty when it has none for that frame. */
class PredictedLabels
{
public:
  PredictedLabels (const RunOutputs& run, RunEvaluationConfig::Labels from) : run_ (run), from_ (from)
  {
    for (const io::StampedPose& p : run.trajectory)
      pose_at_[microseconds (p.timestamp)] = p.pose;
  }

  cv::Mat
  of (const RGBDFrame& frame, std::size_t index, const cv::Size& size) const
  {
    if (from_ == RunEvaluationConfig::Labels::FinalMap)
    {
      const auto pose = pose_at_.find (microseconds (frame.timestamp));
      if (pose == pose_at_.end ())
        return cv::Mat ();  // not fused (tracking lost) or beyond the run's frames
      return rasterizer_.render (run_.mesh, frame.camera, pose->second).labels;
    }
    std::ostringstream name;
    name << std::setw (6) << std::setfill ('0') << index << ".png";
    const fs::path path = fs::path (run_.dir) / "labels" / name.str ();
    if (!fs::exists (path))
      return cv::Mat ();
    cv::Mat predicted = io::readLabelImage (path.string ());
    if (predicted.size () != size)
      throw Error (path.string (), "label image size differs from the sequence's frames");
    return predicted;
  }

private:
  const RunOutputs& run_;
  RunEvaluationConfig::Labels from_;
  std::map<long long, Eigen::Isometry3d, std::less<long long>,
           Eigen::aligned_allocator<std::pair<const long long, Eigen::Isometry3d>>> pose_at_;
  visualization::MeshRasterizer rasterizer_;
};

/** 3D instance AP of a run's map.pcd against the labelled ground-truth cloud. */
InstanceAPResult
scoreInstanceAP (const RunOutputs& run, const io::GroundTruthCloud& truth, const RunEvaluationConfig& config)
{
  const std::string map_path = (fs::path (run.dir) / "map.pcd").string ();
  pcl::PointCloud<pcl::PointXYZL>::Ptr map = pcl::make_shared<pcl::PointCloud<pcl::PointXYZL>> ();
  pcl::fromPCLPointCloud2 (io::readPCD (map_path, {"x", "y", "z", "label"}), *map);
  InstanceEvaluationInput input;
  input.truth.reserve (truth.cloud->size ());
  for (const auto& p : *truth.cloud)
    input.truth.push_back (p.label);
  input.predicted = transferLabels (*truth.cloud, map, config.match_radius > 0.0 ? config.match_radius : 2.0 * run.voxel_size);
  for (const auto& [id, name] : truth.class_names)
    input.truth_instances[id] = {name, truth.ignored.count (id) > 0};
  input.predicted_instances.insert (run.segments.begin (), run.segments.end ());
  return evaluateInstanceAP (input, config.instance_ap);
}
}  // namespace

std::string
defaultRunName (const std::string& dir)
{
  const std::string name = fs::path (dir).filename ().string ();
  return name.empty () || name == "." ? fs::absolute (dir).parent_path ().filename ().string () : name;
}

RunOutputs
readRunOutputs (const std::string& dir, bool with_mesh, const std::string& name)
{
  if (!fs::is_directory (dir))
    throw Error (dir, "is not a `cuefusion run` output folder");
  RunOutputs run;
  run.dir = dir;
  run.name = name.empty () ? defaultRunName (dir) : name;
  const fs::path folder (dir);
  run.trajectory = io::readTumTrajectory ((folder / "trajectory.txt").string ());
  if (with_mesh)
  {
    run.mesh = io::readMeshPLY ((folder / "mesh.ply").string ());
    if (run.mesh.labels.empty ())
      throw Error ((folder / "mesh.ply").string (), "mesh has no per-vertex label (not written by `cuefusion run`?)");
  }
  else if (!fs::is_directory (folder / "labels") || fs::is_empty (folder / "labels"))
    throw Error ((folder / "labels").string (), "no per-frame labels to score (write them with `cuefusion run --save-every K`)");
  for (const segmentation::SegmentEntry& entry : segmentation::readSegmentsJson ((folder / "segments.json").string ()))
  {
    // Segments with a detector score are ranked by it; the rest (geometry only) tie at 1.
    PredictedInstance p;
    p.class_name = entry.class_name;
    if (entry.score >= 0.0)
      p.confidence = entry.score;
    run.segments[entry.id] = p;
  }
  // Older or hand-made folders (and Pipeline.save's) have no voxel size: keep the default.
  if (const std::optional<double> voxel_size = pipeline::readRunFiles (dir, pipeline::kTrackingFile).voxel_size)
    run.voxel_size = *voxel_size;
  return run;
}

std::string
SequenceTruth::classOf (std::uint32_t instance) const
{
  if (!cloud)
    return std::string ();
  const auto it = cloud->class_names.find (instance);
  return it == cloud->class_names.end () ? std::string () : it->second;
}

SequenceTruth
readSequenceTruth (const std::string& source, const io::SequenceOptions& options)
{
  if (options.format == io::SequenceFormat::OpenNI2)
    throw ParameterError ("SequenceOptions::format", "the evaluation needs a recorded sequence folder");
  SequenceTruth truth;
  truth.source = source;
  truth.dataset = io::openDataset (source, options);
  truth.cloud = io::findGroundTruthCloud (source);
  truth.stuff = truth.cloud ? truth.cloud->ignored : io::syntheticStuffInstances (source);
  truth.reference = referenceTrajectory (*truth.dataset);
  return truth;
}

void
RunEvaluationConfig::validate () const
{
  if (every == 0)
    throw ParameterError ("RunEvaluationConfig::every", "must be at least 1");
  frame_iou.validate ();
  instance_ap.validate ();
  if (!(match_radius >= 0.0 && match_radius <= 1.0))
    throw ParameterError ("RunEvaluationConfig::match_radius", "must lie in [0, 1] metres");
  if (!(max_time_difference >= 0.0 && max_time_difference <= 1.0))
    throw ParameterError ("RunEvaluationConfig::max_time_difference", "must lie in [0, 1] seconds");
}

std::vector<RunEvaluation>
evaluateRuns (const std::vector<RunOutputs>& runs, const SequenceTruth& truth, const RunEvaluationConfig& config,
              const std::function<void (std::size_t, std::size_t)>& progress)
{
  config.validate ();
  if (!truth.dataset)
    throw ParameterError ("SequenceTruth::dataset", "is not open (readSequenceTruth opens it)");
  std::vector<RunEvaluation> results (runs.size ());
  std::vector<PredictedLabels> predicted;
  predicted.reserve (runs.size ());
  for (std::size_t k = 0; k < runs.size (); ++k)
  {
    if (config.labels == RunEvaluationConfig::Labels::FinalMap && runs[k].mesh.labels.empty ())
      throw Error ((fs::path (runs[k].dir) / "mesh.ply").string (), "was not read: readRunOutputs (dir, true) reads the final map");
    results[k].tracking = evaluateTracking (runs[k].trajectory, truth.reference, config.max_time_difference);
    predicted.emplace_back (runs[k], config.labels);
  }

  const io::DatasetGrabber& dataset = *truth.dataset;
  for (std::size_t i = 0; i < dataset.size (); i += config.every)
  {
    if (progress)
      progress (i + 1, dataset.size ());
    if (dataset.records ()[i].instance_path.empty ())
      continue;
    const RGBDFrame::Ptr frame = dataset.readFrame (i);
    for (RunEvaluation& result : results)
      ++result.frames_with_masks;
    const cv::Mat objects = objectMask (*frame, truth.stuff);
    const cv::Mat valid = measuredPixels (*frame);
    for (std::size_t k = 0; k < runs.size (); ++k)
    {
      const cv::Mat labels = predicted[k].of (*frame, i, objects.size ());
      if (labels.empty ())
      {
        ++results[k].frames_skipped;
        continue;
      }
      results[k].frame_iou.push_back (frameObjectIoU (labels, objects, valid, config.frame_iou));
      results[k].frame_index.push_back (i);
    }
  }
  for (std::size_t k = 0; k < runs.size (); ++k)
  {
    results[k].object_iou = summarizeObjectIoU (results[k].frame_iou);
    if (truth.cloud)
      results[k].instance_ap = scoreInstanceAP (runs[k], *truth.cloud, config);
  }
  return results;
}

RunEvaluation
evaluateRun (const RunOutputs& run, const SequenceTruth& truth, const RunEvaluationConfig& config)
{
  return evaluateRuns ({run}, truth, config).front ();
}
}  // namespace evaluation
}  // namespace cuefusion
