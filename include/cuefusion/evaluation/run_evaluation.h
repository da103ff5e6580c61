// SPDX-License-Identifier: BSD-3-Clause
#pragma once

#include <cuefusion/evaluation/instance_ap.h>
#include <cuefusion/evaluation/object_iou.h>
#include <cuefusion/evaluation/trajectory_error.h>
#include <cuefusion/io/ground_truth.h>
#include <cuefusion/io/mesh_io.h>
#include <cuefusion/io/pose_io.h>
#include <cuefusion/io/sequence.h>
#include <cuefusion/reconstruction/tsdf_volume.h>

#include <cstddef>
#include <cstdint>
#include <functional>
#include <map>
#include <optional>
#include <set>
#include <string>
#include <vector>

namespace cuefusion
{
namespace evaluation
{
/** \brief What one `cuefusion run` output folder holds, as the evaluation needs it:
  * trajectory.txt, segments.json, the voxel size (tracking.json), and mesh.ply when the
  * per-frame labels come from the final map. map.pcd is read by the 3D AP only.
  */
struct RunOutputs
{
  std::string name;  ///< shown in reports (defaultRunName unless given)
  std::string dir;
  io::Trajectory trajectory;
  io::TriangleMesh mesh;                                 ///< empty unless read with the mesh
  std::map<std::uint32_t, PredictedInstance> segments;  ///< segments.json: id → class, score
  double voxel_size = reconstruction::TSDFVolumeConfig ().voxel_size;  ///< tracking.json's, else the default
};

/** \brief The name a run folder is shown under when none is given: the folder's name
  * (its parent's for "." and paths ending in a separator). */
std::string
defaultRunName (const std::string& dir);

/** \brief Reads the run folder \a dir (its mesh.ply too when \a with_mesh; else it checks
  * that labels/ holds the per-frame labels). Throws cuefusion::Error naming the file that
  * is missing or malformed.
  */
RunOutputs
readRunOutputs (const std::string& dir, bool with_mesh, const std::string& name = std::string ());

/** \brief A sequence's truth: its frames (with instance masks), the reference
  * trajectory, the labelled ground-truth cloud when it has one, and the instances that are
  * not objects (floor, walls: "stuff").
  */
struct SequenceTruth
{
  std::string source;
  io::DatasetGrabber::Ptr dataset;
  io::Trajectory reference;
  std::optional<io::GroundTruthCloud> cloud;
  std::set<std::uint32_t> stuff;

  /** The class name of a ground-truth instance ("" when the sequence names none). */
  std::string classOf (std::uint32_t instance) const;
};

/** \brief Opens the recorded sequence \a source (not a live camera) with its truth.
  * Throws cuefusion::Error naming the file, ParameterError ("SequenceOptions::format")
  * for a live source. */
SequenceTruth
readSequenceTruth (const std::string& source, const io::SequenceOptions& options = io::SequenceOptions ());

/** \brief The chapter 5 procedure's settings (thesis §5.3; ScanNet's for the 3D AP). */
struct RunEvaluationConfig
{
  /** Where a frame's predicted labels come from: the final map (mesh.ply) rendered at
    * the run's pose of that frame, or the run's labels/ images (`run --save-every`). */
  enum class Labels
  {
    FinalMap,
    PerFrame
  };
  Labels labels = Labels::FinalMap;
  std::size_t every = 1;               ///< score every K-th frame
  FrameIoUConfig frame_iou;            ///< per-frame object IoU (min_truth_pixels)
  InstanceAPConfig instance_ap;        ///< 3D AP (min_region_size, ScanNet's)
  double match_radius = 0.0;           ///< 3D AP: truth points take the nearest map point's label within this (m; 0 = two voxels)
  double max_time_difference = 1e-3;   ///< a run's pose and a reference pose pair within this (s)

  /** Throws ParameterError ("RunEvaluationConfig::field", why; the embedded configs' own names). */
  void validate () const;
};

/** \brief Tracking against the reference: ATE, and RPE over one frame and one second
  * (absent where the sequence is shorter than the interval). */
struct TrackingEvaluation
{
  TrajectoryError ate;
  std::optional<RelativePoseError> rpe_frame, rpe_second;
};

/** \brief One run scored against a sequence's truth. */
struct RunEvaluation
{
  std::optional<TrackingEvaluation> tracking;     ///< absent with fewer than 3 pose pairs
  std::vector<std::vector<ObjectIoU>> frame_iou;  ///< per scored frame
  std::vector<std::size_t> frame_index;           ///< the sequence index of each frame_iou entry
  std::size_t frames_skipped = 0;                 ///< frames with truth but no prediction (lost, beyond the run)
  std::size_t frames_with_masks = 0;              ///< frames of the sequence looked at that have instance masks
  SequenceIoU object_iou;                         ///< the per-object means over frame_iou
  std::optional<InstanceAPResult> instance_ap;    ///< when the sequence has a labelled cloud
};

/** \brief The chapter 5 evaluation of \a runs against \a truth: tracking (ATE, RPE),
  * per-frame object IoU on every config.every-th frame with instance masks (stuff
  * instances not scored) and 3D instance AP of each run's map.pcd against the labelled
  * cloud. Each frame of the sequence is read once for all runs. \a progress, when given,
  * is told the frames done. Throws cuefusion::Error naming the file that fails.
  */
std::vector<RunEvaluation>
evaluateRuns (const std::vector<RunOutputs>& runs, const SequenceTruth& truth,
              const RunEvaluationConfig& config = RunEvaluationConfig (),
              const std::function<void (std::size_t done, std::size_t total)>& progress = nullptr);

/** \brief One run: evaluateRuns of it alone. */
RunEvaluation
evaluateRun (const RunOutputs& run, const SequenceTruth& truth, const RunEvaluationConfig& config = RunEvaluationConfig ());
}  // namespace evaluation
}  // namespace cuefusion
