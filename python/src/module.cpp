// SPDX-License-Identifier: BSD-3-Clause
// cuefusion._cuefusion: the library to Python (issue 41). Each class and function here
// converts arrays (arrays.cpp), releases the GIL and calls the library; no algorithm lives
// here. Errors: ParameterError → ValueError, a file that cannot be read or written →
// OSError, any other cuefusion::Error → RuntimeError, each with the library's message.
#include "arrays.h"

#include <cuefusion/common/data_directory.h>
#include <cuefusion/common/exceptions.h>
#include <cuefusion/evaluation/instance_ap.h>
#include <cuefusion/evaluation/object_iou.h>
#include <cuefusion/evaluation/run_evaluation.h>
#include <cuefusion/evaluation/trajectory_error.h>
#include <cuefusion/io/dataset_grabber.h>
#include <cuefusion/io/file_io.h>
#include <cuefusion/io/map_io.h>
#include <cuefusion/io/mesh_io.h>
#include <cuefusion/io/pose_io.h>
#include <cuefusion/io/sequence.h>
#include <cuefusion/pipeline/frame_segmentation.h>
#include <cuefusion/pipeline/fusion_pipeline.h>
#include <cuefusion/pipeline/settings.h>
#include <cuefusion/recognition/mask_folder_segmenter.h>
#include <cuefusion/recognition/onnx_instance_segmenter.h>
#include <cuefusion/recognition/settings.h>
#include <cuefusion/segmentation/object_geometry.h>
#include <cuefusion/segmentation/segments_file.h>

#include <boost/filesystem.hpp>
#include <nlohmann/json.hpp>
#include <pybind11/stl.h>

#include <memory>
#include <mutex>

namespace cuefusion
{
namespace python
{
using namespace pybind11::literals;

namespace
{
/** Runs \a fn with the GIL released; a cuefusion::Error about a file becomes OSError. */
template <typename F>
auto
withFiles (F&& fn) -> decltype (fn ())
{
  try
  {
    const py::gil_scoped_release release;
    return fn ();
  }
  catch (const ParameterError&)
  {
    throw;
  }
  catch (const Error& e)
  {
    raiseOSError (e.what ());
  }
}

/** A settings object: None, a dict, or JSON text; unwraps outputs.json's "config" and a
  * settings file's "pipeline" (or "network" for \a member "network"). */
nlohmann::json
settingsJson (const std::string& text, const std::string& source, const std::string& member)
{
  if (text.empty ())
    return nlohmann::json::object ();
  nlohmann::json json = io::parseJson (text, source);
  if (json.is_object () && json.contains ("config"))
    json = json.at ("config");
  if (json.is_object () && json.contains (member))
    json = json.at (member);
  else if (json.is_object () && (json.contains ("pipeline") || json.contains ("network")))
    json = nlohmann::json::object ();  // a settings file without this part
  return json;
}

/** A frame of a sequence as Python sees it: numpy copies made on access. */
struct Frame
{
  RGBDFrame::Ptr frame;
};

/** A recorded sequence (io::openSequence of a dataset folder), indexable and iterable. */
class Sequence
{
public:
  Sequence (const std::string& path, const std::string& format, const std::string& intrinsics)
  {
    io::SequenceOptions options;
    options.format = io::parseSequenceFormat (format);
    options.intrinsics_path = intrinsics;
    io::RGBDGrabber::Ptr grabber = withFiles ([&] { return io::openSequence (path, options); });
    dataset_ = std::dynamic_pointer_cast<io::DatasetGrabber> (grabber);
    if (!dataset_)
      throw py::value_error (path + ": open_sequence reads recorded sequences (a dataset folder), not cameras");
  }
  std::size_t size () const { return dataset_->size (); }
  Frame
  at (py::ssize_t i) const
  {
    const auto n = static_cast<py::ssize_t> (size ());
    if (i < 0)
      i += n;
    if (i < 0 || i >= n)
      throw py::index_error ("frame index out of range (the sequence has " + std::to_string (n) + " frames)");
    return Frame{withFiles ([&] { return dataset_->readFrame (static_cast<std::size_t> (i)); })};
  }
  py::array K () const { return arrayFromCamera (dataset_->camera ()); }
  std::string format () const { return dataset_->formatName (); }

private:
  io::DatasetGrabber::Ptr dataset_;
};

/** FusionPipeline with the poses it accepted (for save()'s trajectory.txt). */
class Pipeline
{
public:
  Pipeline (const std::string& config_text, const std::string& source, const std::string& mode)
    : fusion_ (makeConfig (config_text, source, mode))
  {
  }

  py::dict
  processFrame (const RGBDFrame& frame, const py::object& masks)
  {
    std::vector<Instance> instances;
    const bool have_masks = instancesFromPython (masks, frame.depth.size (), instances);
    pipeline::PipelineFrameReport report;
    {
      const py::gil_scoped_release release;
      const std::lock_guard<std::mutex> lock (mutex_);
      report = fusion_.process (frame, have_masks ? &instances : nullptr);
      if (report.reconstruction.tracked)
        trajectory_.push_back ({frame.timestamp, report.reconstruction.pose});
    }
    ++frames_;
    return reportDict (report);
  }

  py::dict
  process (const py::array& depth, const py::object& color, const py::object& K, const py::object& masks,
           double depth_scale, const py::object& timestamp, const py::object& pose)
  {
    RGBDFrame frame = frameFromArrays (depth, color, K, depth_scale);
    frame.index = frames_;
    frame.name = std::to_string (frames_);
    frame.timestamp = timestamp.is_none () ? static_cast<double> (frames_) / 30.0 : timestamp.cast<double> ();
    if (!pose.is_none ())
      frame.pose = poseFromArray (pose, "pose");
    return processFrame (frame, masks);
  }

  py::tuple
  labelledCloud (bool color_by_segment) const
  {
    pcl::PointCloud<pcl::PointXYZRGBL>::Ptr cloud;
    {
      const py::gil_scoped_release release;
      const std::lock_guard<std::mutex> lock (mutex_);
      cloud = fusion_.labelledCloud (color_by_segment);
    }
    const auto n = static_cast<py::ssize_t> (cloud->size ());
    py::array_t<float> xyz ({n, py::ssize_t (3)});
    py::array_t<std::uint8_t> rgb ({n, py::ssize_t (3)});
    py::array_t<std::uint32_t> labels (n);
    float* p = xyz.mutable_data ();
    std::uint8_t* c = rgb.mutable_data ();
    std::uint32_t* l = labels.mutable_data ();
    for (const pcl::PointXYZRGBL& q : cloud->points)
    {
      *p++ = q.x, *p++ = q.y, *p++ = q.z;
      *c++ = q.r, *c++ = q.g, *c++ = q.b;
      *l++ = q.label;
    }
    return py::make_tuple (xyz, rgb, labels);
  }

  py::tuple
  mesh (bool color_by_segment) const
  {
    io::TriangleMesh m;
    {
      const py::gil_scoped_release release;
      const std::lock_guard<std::mutex> lock (mutex_);
      m = fusion_.labelledTriangleMesh (color_by_segment);
    }
    const auto n = static_cast<py::ssize_t> (m.vertices.size ()), t = static_cast<py::ssize_t> (m.triangles.size ());
    py::array_t<float> vertices ({n, py::ssize_t (3)});
    py::array_t<std::int32_t> triangles ({t, py::ssize_t (3)});
    py::array_t<std::uint8_t> colors ({m.colors.empty () ? py::ssize_t (0) : n, py::ssize_t (3)});
    py::array_t<std::uint32_t> labels (m.labels.empty () ? py::ssize_t (0) : n);
    for (py::ssize_t i = 0; i < n; ++i)
      for (int k = 0; k < 3; ++k)
        vertices.mutable_at (i, k) = m.vertices[static_cast<std::size_t> (i)][k];
    for (py::ssize_t i = 0; i < t; ++i)
      for (int k = 0; k < 3; ++k)
        triangles.mutable_at (i, k) = m.triangles[static_cast<std::size_t> (i)][k];
    for (std::size_t i = 0; i < m.colors.size (); ++i)
      for (int k = 0; k < 3; ++k)
        colors.mutable_at (static_cast<py::ssize_t> (i), k) = m.colors[i][static_cast<std::size_t> (k)];
    for (std::size_t i = 0; i < m.labels.size (); ++i)
      labels.mutable_at (static_cast<py::ssize_t> (i)) = m.labels[i];
    return py::make_tuple (vertices, triangles, colors, labels);
  }

  /** segments.json's text (the binding's Python side parses it into dicts). */
  std::string
  segmentsText ()
  {
    const py::gil_scoped_release release;
    const std::lock_guard<std::mutex> lock (mutex_);
    const auto cloud = fusion_.labelledCloud ();
    return segmentation::segmentsJsonText (fusion_.segments (), segmentation::objectGeometry (*cloud));
  }

  /** map.pcd, mesh.ply, segments.json and trajectory.txt into \a folder, as `cuefusion run` writes them. */
  void
  save (const std::string& folder)
  {
    withFiles ([&] {
      const std::lock_guard<std::mutex> lock (mutex_);
      boost::system::error_code ec;
      boost::filesystem::create_directories (folder, ec);
      if (ec || !boost::filesystem::is_directory (folder))
        throw Error (folder, "cannot create folder" + (ec ? ": " + ec.message () : std::string ()));
      const boost::filesystem::path dir (folder);
      std::map<std::uint32_t, segmentation::ObjectGeometry> geometry;
      {
        const auto cloud = fusion_.labelledCloud ();
        io::saveMapPCD ((dir / "map.pcd").string (), *cloud);
        geometry = segmentation::objectGeometry (*cloud);
      }
      io::writeMeshPLY ((dir / "mesh.ply").string (), fusion_.labelledTriangleMesh (true));
      segmentation::writeSegmentsJson ((dir / "segments.json").string (), fusion_.segments (), geometry);
      io::writeTumTrajectory ((dir / "trajectory.txt").string (), trajectory_);
      return 0;
    });
  }

  py::list
  trajectory () const
  {
    io::Trajectory copy;
    {
      const py::gil_scoped_release release;
      const std::lock_guard<std::mutex> lock (mutex_);
      copy = trajectory_;
    }
    py::list out;
    for (const io::StampedPose& p : copy)
      out.append (py::make_tuple (p.timestamp, arrayFromPose (p.pose)));
    return out;
  }
  std::size_t frames () const { return frames_; }
  float
  noiseScale () const
  {
    const py::gil_scoped_release release;
    const std::lock_guard<std::mutex> lock (mutex_);
    return fusion_.noiseScale ();
  }
  py::dict config () const { return py::module_::import ("json").attr ("loads") (io::jsonText (pipeline::configJson (fusion_.getConfig ()), -1)); }

private:
  static pipeline::FusionPipelineConfig
  makeConfig (const std::string& text, const std::string& source, const std::string& mode)
  {
    pipeline::FusionPipelineConfig config;
    pipeline::readConfig (settingsJson (text, source, "pipeline"), config);
    if (!mode.empty ())
      config.mode = pipeline::parseSegmentationMode (mode);
    config.validate ();
    return config;
  }

  static py::dict
  reportDict (const pipeline::PipelineFrameReport& report)
  {
    const reconstruction::FrameReport& r = report.reconstruction;
    const reconstruction::StageTimings& t = r.timings;
    const pipeline::SegmentationTimings& s = report.segmentation;
    py::dict timings ("preprocess"_a = t.preprocess_ms, "track"_a = t.track_ms, "integrate"_a = t.integrate_ms,
                      "raycast"_a = t.raycast_ms, "relocalise"_a = t.relocalise_ms, "geometric_segmentation"_a = s.geometry_ms,
                      "instance_merge"_a = s.instances_ms, "propagation"_a = s.propagation_ms,
                      "segment_merging"_a = s.merging_ms, "label_update"_a = s.update_ms);
    return py::dict ("index"_a = r.index, "timestamp"_a = r.timestamp, "tracked"_a = r.tracked,
                     "pose"_a = arrayFromPose (r.pose), "lost_reason"_a = r.failure, "relocalised"_a = r.relocalised,
                     "relocalised_from"_a = r.relocalised_from, "segmented"_a = report.segmented,
                     "had_masks"_a = report.had_masks, "segments"_a = report.frame_segments,
                     "noise_scale"_a = report.noise_scale, "timings_ms"_a = timings, "loop_ms"_a = report.loop_ms);
  }

  /// The GIL is released while the library works, so two Python threads may call one
  /// Pipeline at once: every use of fusion_ and trajectory_ holds this (taken after the
  /// GIL is let go, released before it is taken back).
  mutable std::mutex mutex_;
  pipeline::FusionPipeline fusion_;
  io::Trajectory trajectory_;
  std::size_t frames_ = 0;
};

/** A mask (CV_8U, non-zero = the instance) as a numpy bool array, in one pass. */
py::array
boolArrayFromMask (const cv::Mat& mask)
{
  py::array out (py::dtype ("?"), std::vector<py::ssize_t> {mask.rows, mask.cols});
  cv::Mat ones (mask.size (), CV_8U, out.mutable_data ());  // numpy's bool: one byte, 0 or 1
  cv::min (mask, 1, ones);
  return out;
}

/** A mask source: the shipped network or an ONNX file, or a folder of id PNGs. */
class Segmenter
{
public:
  Segmenter (const std::string& source, const std::string& options_json)
  {
    boost::system::error_code ec;
    if (boost::filesystem::is_directory (source, ec))
      inner_ = withFiles ([&] { return std::make_shared<recognition::MaskFolderSegmenter> (source); });
    else
    {
      recognition::OnnxInstanceSegmenterConfig config;
      recognition::readConfig (settingsJson (options_json, "options", "network"), config);
      config.model_path = source;  // after the options, which must not replace the source
      config.validate ();
      inner_ = withFiles ([&] { return std::make_shared<recognition::OnnxInstanceSegmenter> (config); });
    }
  }

  py::list
  call (const py::array& depth, const py::object& color, const py::object& K, double depth_scale, std::size_t index,
        const std::string& name)
  {
    RGBDFrame frame = frameFromArrays (depth, color, K, depth_scale);
    frame.index = index;
    frame.name = name.empty () ? std::to_string (index) : name;
    std::vector<Instance> instances;
    const bool have = withFiles ([&] {
      const std::lock_guard<std::mutex> lock (mutex_);  // a network is one object: one frame at a time
      return inner_->segment (frame, instances);
    });
    py::list out;
    if (have)
      for (const Instance& instance : instances)
        out.append (py::make_tuple (boolArrayFromMask (instance.mask), instance.score,
                                    instance.class_name.empty () ? py::object (py::none ()) : py::str (instance.class_name)));
    return out;
  }
  std::string name () const { return inner_->name (); }

private:
  std::mutex mutex_;  ///< as Pipeline's
  recognition::InstanceSegmenter::Ptr inner_;
};

py::array
segmentFrame (const py::array& depth, const py::object& color, const py::object& K, const py::object& masks,
              const std::string& mode, double depth_scale, const std::string& config_text)
{
  const RGBDFrame frame = frameFromArrays (depth, color, K, depth_scale);
  std::vector<Instance> instances;
  const bool have_masks = instancesFromPython (masks, frame.depth.size (), instances);
  pipeline::FusionPipelineConfig defaults;
  pipeline::readConfig (settingsJson (config_text, "config", "pipeline"), defaults);
  pipeline::FrameSegmentationConfig config;
  config.geometry = defaults.geometry;
  config.instance_merge = defaults.instance_merge;
  config.mode = pipeline::parseSegmentationMode (mode);
  if (config.mode != pipeline::SegmentationMode::Geometry && !have_masks)
    throw py::value_error ("mode '" + mode + "' needs masks (or use mode='geometry')");
  cv::Mat labels;
  {
    const py::gil_scoped_release release;
    pipeline::FrameSegmentation segmentation (config);
    labels = segmentation.segmentGeometry (toPointCloud (frame)).clone ();
    if (config.mode != pipeline::SegmentationMode::Geometry)
      labels = segmentation.applyMasks (instances, frame.color);
  }
  return arrayFromMat (labels);
}

io::Trajectory
trajectoryFromPython (const py::object& object, const std::string& name)
{
  if (py::isinstance<py::str> (object) || py::hasattr (object, "__fspath__"))
  {
    const std::string path = py::str (py::module_::import ("os").attr ("fspath") (object));
    return withFiles ([&] { return io::readTumTrajectory (path); });
  }
  io::Trajectory trajectory;
  for (const py::handle item : object)
  {
    const py::sequence pair = py::reinterpret_borrow<py::sequence> (item);
    if (pair.size () != 2)
      throw py::value_error (name + " must be a TUM file or a list of (timestamp, 4x4 pose)");
    trajectory.push_back ({pair[0].cast<double> (), poseFromArray (pair[1], name + "'s pose")});
  }
  return trajectory;
}

py::dict
evaluateTrajectory (const py::object& estimated, const py::object& reference, double max_time_difference, bool align)
{
  const io::Trajectory e = trajectoryFromPython (estimated, "estimated"), r = trajectoryFromPython (reference, "reference");
  evaluation::TrajectoryError ate;
  {
    const py::gil_scoped_release release;
    ate = evaluation::absoluteTrajectoryError (e, r, max_time_difference, align);
  }
  return py::dict ("rmse"_a = ate.rmse, "mean"_a = ate.mean, "median"_a = ate.median, "max"_a = ate.max, "pairs"_a = ate.pairs,
                   "alignment"_a = arrayFromPose (ate.alignment));
}

/** An integer label image as CV_32S (a copy). */
cv::Mat
labelImage (const py::object& object, const std::string& name)
{
  if (!py::isinstance<py::array> (object))
    throw py::value_error (name + " must be a numpy array");
  const py::array a = py::reinterpret_borrow<py::array> (object);
  const char kind = a.dtype ().kind ();
  if (a.ndim () != 2 || (kind != 'i' && kind != 'u'))
    throw py::value_error (name + " must be an HxW integer label image");
  if (!(a.flags () & py::array::c_style))
    throw py::value_error (name + " must be C-contiguous (numpy.ascontiguousarray makes it so)");
  const py::array_t<std::int32_t, py::array::c_style | py::array::forcecast> labels (a);
  cv::Mat out (static_cast<int> (a.shape (0)), static_cast<int> (a.shape (1)), CV_32S);
  std::memcpy (out.data, labels.data (), out.total () * sizeof (std::int32_t));
  return out;
}

py::dict
evaluateLabels (const py::object& predicted, const py::object& truth, std::size_t min_truth_pixels)
{
  const cv::Mat p = labelImage (predicted, "predicted"), t = labelImage (truth, "truth");
  if (p.size () != t.size ())
    throw py::value_error ("predicted and truth must be of one size");
  evaluation::FrameIoUConfig config;
  config.min_truth_pixels = min_truth_pixels;
  const std::vector<evaluation::ObjectIoU> objects = evaluation::frameObjectIoU (p, t, cv::Mat (), config);
  py::list list;
  double sum = 0.0;
  for (const evaluation::ObjectIoU& o : objects)
  {
    list.append (py::dict ("instance"_a = o.instance, "segment"_a = o.segment, "iou"_a = o.iou, "truth_pixels"_a = o.truth_pixels,
                           "segment_pixels"_a = o.segment_pixels, "intersection"_a = o.intersection));
    sum += o.iou;
  }
  return py::dict ("mean_iou"_a = objects.empty () ? 0.0 : sum / static_cast<double> (objects.size ()), "objects"_a = list);
}

std::vector<std::uint32_t>
pointLabels (const py::object& object, const std::string& name)
{
  const py::array a = py::array::ensure (object);
  if (!a || a.ndim () != 1 || (a.dtype ().kind () != 'i' && a.dtype ().kind () != 'u'))
    throw py::value_error (name + " must be a 1-D integer array of labels per point");
  const py::array_t<std::int64_t, py::array::c_style | py::array::forcecast> v (a);
  std::vector<std::uint32_t> out (static_cast<std::size_t> (v.size ()));
  for (std::size_t i = 0; i < out.size (); ++i)
  {
    if (v.data ()[i] < 0 || v.data ()[i] > 0xffffffffLL)
      throw py::value_error (name + " holds a label outside [0, 2^32)");
    out[i] = static_cast<std::uint32_t> (v.data ()[i]);
  }
  return out;
}

py::dict
evaluateInstances (const py::object& predicted, const py::object& truth, const py::dict& predicted_scores,
                   const py::dict& truth_classes, const py::dict& predicted_classes, std::size_t min_region_size)
{
  evaluation::InstanceEvaluationInput input;
  input.predicted = pointLabels (predicted, "predicted");
  input.truth = pointLabels (truth, "truth");
  if (input.predicted.size () != input.truth.size ())
    throw py::value_error ("predicted and truth must label the same points (equal lengths)");
  for (const auto& [id, name] : truth_classes)
    input.truth_instances[id.cast<std::uint32_t> ()].class_name = name.cast<std::string> ();
  for (const auto& [id, score] : predicted_scores)
    input.predicted_instances[id.cast<std::uint32_t> ()].confidence = score.cast<double> ();
  for (const auto& [id, name] : predicted_classes)
    input.predicted_instances[id.cast<std::uint32_t> ()].class_name = name.cast<std::string> ();
  evaluation::InstanceAPConfig config;
  config.min_region_size = min_region_size;
  evaluation::InstanceAPResult result;
  {
    const py::gil_scoped_release release;
    result = evaluation::evaluateInstanceAP (input, config);
  }
  const auto scores = [] (const evaluation::APScores& a) { return py::dict ("ap"_a = a.ap, "ap50"_a = a.ap50, "ap25"_a = a.ap25); };
  py::dict per_class;
  for (const auto& [name, a] : result.per_class)
    per_class[py::str (name)] = scores (a);
  py::dict out = scores (result.class_agnostic);
  out["per_class"] = per_class;
  out["truth_instances"] = result.truth_instances;
  out["predicted_instances"] = result.predicted_instances;
  return out;
}

py::object
rpeDict (const std::optional<evaluation::RelativePoseError>& rpe)
{
  if (!rpe)
    return py::none ();
  return py::dict ("pairs"_a = rpe->pairs, "translation_rmse"_a = rpe->translation_rmse, "translation_median"_a = rpe->translation_median,
                   "rotation_rmse_deg"_a = rpe->rotation_rmse_deg, "rotation_median_deg"_a = rpe->rotation_median_deg);
}

/** The chapter 5 evaluation of one run folder against its sequence (`cuefusion eval`). */
py::dict
evaluateRun (const std::string& run, const std::string& sequence, const std::string& labels, std::size_t every, std::size_t min_pixels,
             std::size_t min_region, double match_radius, const std::string& format, const std::string& intrinsics)
{
  evaluation::RunEvaluationConfig config;
  if (labels != "final" && labels != "per-frame")
    throw py::value_error ("labels must be 'final' or 'per-frame', not '" + labels + "'");
  config.labels = labels == "final" ? evaluation::RunEvaluationConfig::Labels::FinalMap : evaluation::RunEvaluationConfig::Labels::PerFrame;
  config.every = every;
  config.frame_iou.min_truth_pixels = min_pixels;
  config.instance_ap.min_region_size = min_region;
  config.match_radius = match_radius;
  config.validate ();
  io::SequenceOptions options;
  options.format = io::parseSequenceFormat (format);
  options.intrinsics_path = intrinsics;
  const evaluation::RunEvaluation found = withFiles ([&] {
    const evaluation::RunOutputs outputs = evaluation::readRunOutputs (run, config.labels == evaluation::RunEvaluationConfig::Labels::FinalMap);
    return evaluation::evaluateRun (outputs, evaluation::readSequenceTruth (sequence, options), config);
  });
  py::object tracking = py::none ();
  if (found.tracking)
  {
    const evaluation::TrajectoryError& ate = found.tracking->ate;
    tracking = py::dict ("pairs"_a = ate.pairs,
                         "ate"_a = py::dict ("rmse"_a = ate.rmse, "mean"_a = ate.mean, "median"_a = ate.median, "max"_a = ate.max),
                         "rpe_frame"_a = rpeDict (found.tracking->rpe_frame), "rpe_second"_a = rpeDict (found.tracking->rpe_second));
  }
  py::dict objects;
  for (const auto& [id, mean] : found.object_iou.object_mean)
    objects[py::int_ (id)] = py::dict ("mean_iou"_a = mean, "frames"_a = found.object_iou.object_frames.at (id));
  const py::dict object_iou ("mean"_a = found.frame_iou.empty () ? py::object (py::none ()) : py::object (py::float_ (found.object_iou.mean)),
                             "frames_scored"_a = found.frame_iou.size (), "frames_skipped"_a = found.frames_skipped,
                             "frames_with_masks"_a = found.frames_with_masks, "objects"_a = objects);
  py::object instance_ap = py::none ();
  if (found.instance_ap)
  {
    const auto scores = [] (const evaluation::APScores& a) { return py::dict ("ap"_a = a.ap, "ap50"_a = a.ap50, "ap25"_a = a.ap25); };
    py::dict per_class;
    for (const auto& [name, a] : found.instance_ap->per_class)
      per_class[py::str (name)] = scores (a);
    py::dict ap = scores (found.instance_ap->class_agnostic);
    ap["per_class"] = per_class;
    ap["truth_instances"] = found.instance_ap->truth_instances;
    ap["predicted_instances"] = found.instance_ap->predicted_instances;
    instance_ap = ap;
  }
  return py::dict ("tracking"_a = tracking, "object_iou"_a = object_iou, "instance_ap"_a = instance_ap);
}

void
bindClasses (py::module_& m)
{
  py::class_<Frame> (m, "Frame", "A frame of a recorded sequence; each attribute is a numpy copy.")
    .def_property_readonly ("depth", [] (const Frame& f) { return arrayFromMat (f.frame->depth); }, "HxW float32, metres (0 = no depth)")
    .def_property_readonly ("color", [] (const Frame& f) { return rgbArrayFromBgr (f.frame->color); }, "HxWx3 uint8, RGB")
    .def_property_readonly ("K", [] (const Frame& f) { return arrayFromCamera (f.frame->camera); }, "3x3 intrinsic matrix")
    .def_property_readonly ("pose", [] (const Frame& f) -> py::object {
      return f.frame->pose ? py::object (arrayFromPose (*f.frame->pose)) : py::object (py::none ()); }, "4x4 camera-to-world, or None")
    .def_property_readonly ("instance_mask", [] (const Frame& f) -> py::object {
      return f.frame->instance_mask.empty () ? py::object (py::none ()) : py::object (arrayFromMat (f.frame->instance_mask)); },
      "HxW uint16 instance ids of the dataset's own masks, or None")
    .def_property_readonly ("index", [] (const Frame& f) { return f.frame->index; })
    .def_property_readonly ("timestamp", [] (const Frame& f) { return f.frame->timestamp; })
    .def_property_readonly ("name", [] (const Frame& f) { return f.frame->name; })
    .def ("__repr__", [] (const Frame& f) { return "<cuefusion.Frame " + std::to_string (f.frame->index) + " '" + f.frame->name + "'>"; });
  py::class_<Sequence> (m, "Sequence", "A recorded sequence: len(), [i] and iteration give Frames.")
    .def ("__len__", &Sequence::size)
    .def ("__getitem__", &Sequence::at)
    .def_property_readonly ("K", &Sequence::K)
    .def_property_readonly ("format", &Sequence::format);
  py::class_<Pipeline> (m, "_Pipeline")
    .def (py::init<const std::string&, const std::string&, const std::string&> ())
    .def ("process_frame", [] (Pipeline& p, const Frame& f, const py::object& masks) { return p.processFrame (*f.frame, masks); })
    .def ("process", &Pipeline::process)
    .def ("labelled_cloud", &Pipeline::labelledCloud)
    .def ("mesh", &Pipeline::mesh)
    .def ("segments_text", &Pipeline::segmentsText)
    .def ("save", &Pipeline::save)
    .def ("trajectory", &Pipeline::trajectory)
    .def_property_readonly ("frames", &Pipeline::frames)
    .def_property_readonly ("noise_scale", &Pipeline::noiseScale)
    .def_property_readonly ("config", &Pipeline::config);
  py::class_<Segmenter> (m, "_Segmenter")
    .def (py::init<const std::string&, const std::string&> ())
    .def ("call", &Segmenter::call)
    .def_property_readonly ("name", &Segmenter::name);
}

void
bindFunctions (py::module_& m)
{
  m.def ("_open_sequence", [] (const std::string& path, const std::string& format, const std::string& intrinsics) {
    return Sequence (path, format, intrinsics);
  });
  m.def ("_segment_frame", &segmentFrame);
  m.def ("_evaluate_trajectory", &evaluateTrajectory);
  m.def ("_evaluate_labels", &evaluateLabels);
  m.def ("_evaluate_instances", &evaluateInstances);
  m.def ("_evaluate_run", &evaluateRun);
}
}  // namespace
}  // namespace python
}  // namespace cuefusion

PYBIND11_MODULE (_cuefusion, m)
{
  namespace py = pybind11;
  py::register_exception_translator ([] (std::exception_ptr p) {
    try
    {
      if (p)
        std::rethrow_exception (p);
    }
    catch (const cuefusion::ParameterError& e)
    {
      PyErr_SetString (PyExc_ValueError, e.what ());
    }
    catch (const cuefusion::Error& e)
    {
      PyErr_SetString (PyExc_RuntimeError, e.what ());
    }
  });
  m.doc () = "cuefusion's C++ core (the cuefusion package wraps it)";
  m.attr ("__version__") = cuefusion::version ();
  cuefusion::python::bindClasses (m);
  cuefusion::python::bindFunctions (m);
}
