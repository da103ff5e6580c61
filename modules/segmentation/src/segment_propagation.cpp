#include <cuefusion/common/exceptions.h>
#include <cuefusion/reconstruction/tsdf_volume.h>
#include <cuefusion/segmentation/edge_operators.h>
#include <cuefusion/segmentation/parallel.h>
#include <cuefusion/segmentation/segment_propagation.h>

#include <algorithm>
#include <atomic>
#include <cmath>

namespace cuefusion
{
namespace segmentation
{
void
SegmentPropagationConfig::validate () const
{
  if (!(normal_agreement >= -1.f && normal_agreement <= 1.f))
    throw ParameterError ("--propagation-normal", "must lie in [-1, 1]");
  if (!(inherit_overlap >= 0.f && inherit_overlap < 1.f) || !(candidate_overlap >= 0.f && candidate_overlap < 1.f))
    throw ParameterError ("--propagation-overlap", "must lie in [0, 1)");
  if (!(noise_factor > 0.f && std::isfinite (noise_factor)))
    throw ParameterError ("--propagation-noise-factor", "must be positive");
  if (min_segment_size < 1)
    throw ParameterError ("--min-segment-size", "must be at least 1 pixel");
}

void
SegmentUpdateConfig::validate () const
{
  if (max_confidence < 1 || max_confidence > 255)
    throw ParameterError ("--max-label-confidence", "must lie in [1, 255]");
  if (!(band > 0.f && band <= 1.f))
    throw ParameterError ("--label-band", "must lie in (0, 1] truncation units");
}

SegmentPropagation::SegmentPropagation (const SegmentPropagationConfig& config) : config_ (config) { config_.validate (); }

void
SegmentPropagation::propagate (const cv::Mat& vertices, const cv::Mat& normals, const cv::Mat& frame_labels,
                               const cv::Mat& model_vertices, const cv::Mat& model_normals, const cv::Mat& model_labels,
                               GlobalSegmentMap& map, std::size_t frame, PropagationResult& result,
                               const std::vector<SegmentInstance>* segments) const
{
  const cv::Size size = frame_labels.size ();
  for (const cv::Mat* m : {&vertices, &normals, &model_vertices, &model_normals})
    if (m->type () != CV_32FC3 || m->size () != size)
      throw Error ("SegmentPropagation", "vertex and normal maps must be CV_32FC3 of L_t's size");
  if (frame_labels.type () != CV_32S || model_labels.type () != CV_32S || model_labels.size () != size)
    throw Error ("SegmentPropagation", "label maps must be CV_32S of one size");

  // #l_j and Π(l_i, l_j) over the pixels where both maps agree (§4.2.2.3). Frame labels
  // are small (1..N), so per-label vectors; each holds the few (l_i, Π) it meets.
  double max_frame_label = 0.0;
  cv::minMaxLoc (frame_labels, nullptr, &max_frame_label);
  const std::size_t labels = static_cast<std::size_t> (std::max (0.0, max_frame_label)) + 1;
  std::vector<int> frame_count (labels, 0);
  std::vector<std::vector<std::pair<std::uint32_t, int>>> by_frame_label (labels);
  for (int y = 0; y < size.height; ++y)
  {
    const std::int32_t* lj = frame_labels.ptr<std::int32_t> (y);
    const std::int32_t* li = model_labels.ptr<std::int32_t> (y);
    const cv::Vec3f* v_row = vertices.ptr<cv::Vec3f> (y);
    const cv::Vec3f* n_row = normals.ptr<cv::Vec3f> (y);
    const cv::Vec3f* vm_row = model_vertices.ptr<cv::Vec3f> (y);
    const cv::Vec3f* nm_row = model_normals.ptr<cv::Vec3f> (y);
    for (int x = 0; x < size.width; ++x)
    {
      if (lj[x] <= 0)
        continue;
      ++frame_count[static_cast<std::size_t> (lj[x])];
      if (li[x] <= 0)
        continue;
      const Eigen::Vector3f V (v_row[x][0], v_row[x][1], v_row[x][2]), N (n_row[x][0], n_row[x][1], n_row[x][2]);
      const Eigen::Vector3f Vm (vm_row[x][0], vm_row[x][1], vm_row[x][2]), Nm (nm_row[x][0], nm_row[x][1], nm_row[x][2]);
      if (!isFiniteVector (V) || !isFiniteVector (N) || !isFiniteVector (Vm) || !isFiniteVector (Nm))
        continue;
      if (!(N.dot (Nm) > config_.normal_agreement))
        continue;
      const float along_ray = std::abs ((V - Vm).dot (V)) / V.norm ();
      if (!(along_ray < config_.noise_factor * axialNoiseLowerBound (V.z ())) &&
          !(along_ray < config_.noise_factor * axialNoiseAt (V, N)))
        continue;
      const std::uint32_t global = map.resolve (static_cast<std::uint32_t> (li[x]));
      auto& list = by_frame_label[static_cast<std::size_t> (lj[x])];
      auto it = std::find_if (list.begin (), list.end (), [global] (const std::pair<std::uint32_t, int>& e) {
        return e.first == global;
      });
      if (it == list.end ())
        list.emplace_back (global, 1);
      else
        ++it->second;
    }
  }

  // §4.2.2.4: inherit, fresh label, or drop; candidates of §4.2.3.
  result = PropagationResult ();
  std::vector<std::uint32_t> given (labels, 0);
  for (std::size_t j = 1; j < labels; ++j)
  {
    const int count = frame_count[j];
    if (count == 0)
      continue;
    std::uint32_t label = 0;
    if (count < config_.min_segment_size)
      ++result.dropped;
    else
    {
      auto& list = by_frame_label[j];
      std::sort (list.begin (), list.end ());
      std::uint32_t best = 0;
      int best_count = 0;
      for (const auto& [li, c] : list)
        if (c > best_count)
        {
          best = li;
          best_count = c;
        }
      if (best && static_cast<float> (best_count) > config_.inherit_overlap * static_cast<float> (count))
      {
        label = best;
        ++result.inherited;
      }
      else
      {
        label = map.newSegment (frame);
        ++result.fresh;
      }
      for (const auto& [li, c] : list)
        if (li != label && static_cast<float> (c) > config_.candidate_overlap * static_cast<float> (count))
          result.candidates.emplace_back (label, li);
      const SegmentInstance* info =
        segments && j < segments->size () ? &(*segments)[j] : nullptr;
      map.observe (label, frame, info);
    }
    given[j] = label;
  }
  result.labels.create (size, CV_32S);
  for (int y = 0; y < size.height; ++y)
  {
    const std::int32_t* lj = frame_labels.ptr<std::int32_t> (y);
    std::int32_t* out = result.labels.ptr<std::int32_t> (y);
    for (int x = 0; x < size.width; ++x)
      out[x] = lj[x] > 0 ? static_cast<std::int32_t> (given[static_cast<std::size_t> (lj[x])]) : 0;
  }
}

std::size_t
updateVoxelLabels (reconstruction::TSDFVolume& volume, const cv::Mat& labels, const cv::Mat& depth, const PinholeCamera& camera,
                   const Eigen::Isometry3d& pose, const GlobalSegmentMap& map, const SegmentUpdateConfig& config)
{
  config.validate ();
  if (labels.type () != CV_32S || labels.cols != camera.width || labels.rows != camera.height)
    throw Error ("updateVoxelLabels", "L^p must be CV_32S of the camera's size");
  if (depth.type () != CV_32F || depth.size () != labels.size ())
    throw Error ("updateVoxelLabels", "depth must be CV_32F of L^p's size");
  const float truncation = static_cast<float> (volume.config ().truncation ());
  const Eigen::Isometry3f world_to_camera = pose.inverse ().cast<float> ();
  const std::vector<std::int32_t>& ids = volume.lastIntegratedBlocks ();
  std::atomic<std::size_t> writes (0);
  const auto max_confidence = static_cast<std::uint8_t> (config.max_confidence);
  // Positions are stepped through each block in the camera frame, as integration does.
  const float voxel_size = static_cast<float> (volume.config ().voxel_size);
  const Eigen::Matrix3f R = world_to_camera.linear ();
  const Eigen::Vector3f dx = R.col (0) * voxel_size, dy = R.col (1) * voxel_size, dz = R.col (2) * voxel_size;
  const float fx = static_cast<float> (camera.fx), fy = static_cast<float> (camera.fy);
  const float cx = static_cast<float> (camera.cx), cy = static_cast<float> (camera.cy);
  const float max_gap = config.band * truncation;
  parallelForChunks (static_cast<int> (ids.size ()), 16, [&] (int, int begin, int end) {
    std::size_t local_writes = 0;
    for (int k = begin; k < end; ++k)
    {
      const std::size_t id = static_cast<std::size_t> (ids[static_cast<std::size_t> (k)]);
      auto& voxels = volume.voxels (id);
      const Eigen::Vector3f origin = world_to_camera * volume.voxelPosition (volume.blocks ()[id]->index * reconstruction::kBlockSide);
      for (int z = 0; z < reconstruction::kBlockSide; ++z)
        for (int y = 0; y < reconstruction::kBlockSide; ++y)
        {
          Eigen::Vector3f p = origin + dy * static_cast<float> (y) + dz * static_cast<float> (z);
          reconstruction::TsdfVoxel* voxel = &voxels[static_cast<std::size_t> (reconstruction::localVoxelIndex (0, y, z))];
          for (int x = 0; x < reconstruction::kBlockSide; ++x, p += dx, ++voxel)
          {
            if (voxel->weight <= 0.f || !(std::abs (voxel->sdf) < config.band) || p.z () <= 0.f)
              continue;
            const float inv_z = 1.f / p.z ();
            const int px = fastFloor (fx * p.x () * inv_z + cx + 0.5f), py = fastFloor (fy * p.y () * inv_z + cy + 0.5f);
            if (px < 0 || py < 0 || px >= labels.cols || py >= labels.rows)
              continue;
            const std::int32_t observed = labels.at<std::int32_t> (py, px);
            if (observed <= 0 || !(std::abs (p.z () - depth.at<float> (py, px)) < max_gap))
              continue;  // unlabelled, or the pixel sees another surface (occlusion)
            const std::uint32_t label = static_cast<std::uint32_t> (observed);
            if (voxel->label == 0)
            {
              voxel->label = label;
              voxel->label_confidence = 0;
              ++local_writes;
            }
            else if (map.resolve (voxel->label) == map.resolve (label))
            {
              if (voxel->label_confidence < max_confidence)
              {
                ++voxel->label_confidence;
                ++local_writes;
              }
            }
            else
            {
              if (voxel->label_confidence > 0)
                --voxel->label_confidence;
              if (voxel->label_confidence == 0)
                voxel->label = label;
              ++local_writes;
            }
          }
        }
    }
    writes += local_writes;
  });
  return writes.load ();
}

cv::Mat
resolveLabels (const cv::Mat& labels, const GlobalSegmentMap& map)
{
  CV_Assert (labels.type () == CV_32S);
  cv::Mat out (labels.size (), CV_32S);
  for (int y = 0; y < labels.rows; ++y)
    for (int x = 0; x < labels.cols; ++x)
    {
      const std::int32_t l = labels.at<std::int32_t> (y, x);
      out.at<std::int32_t> (y, x) = l > 0 ? static_cast<std::int32_t> (map.resolve (static_cast<std::uint32_t> (l))) : 0;
    }
  return out;
}
}  // namespace segmentation
}  // namespace cuefusion
