// SPDX-License-Identifier: BSD-3-Clause
#pragma once

#include <cuefusion/common/pinhole_camera.h>
#include <cuefusion/common/rgbd_frame.h>
#include <cuefusion/common/sensor_defaults.h>
#include <cuefusion/common/triangle_mesh.h>
#include <cuefusion/reconstruction/voxel.h>
#include <cuefusion/reconstruction/voxel_block_store.h>

#include <Eigen/Geometry>
#include <opencv2/core.hpp>

#include <pcl/PolygonMesh.h>
#include <pcl/point_cloud.h>
#include <pcl/point_types.h>

#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

namespace cuefusion
{
namespace reconstruction
{
/** \brief TSDF volume parameters (§4.1.4). */
struct TSDFVolumeConfig
{
  double voxel_size = 0.01;          ///< metres
  /** Truncation distance τ in voxels. FusionPipeline multiplies it by the measured depth
    * noise over the Kinect model's when above 1 (a sensor whose noise reaches τ leaves a
    * single frame's zero crossing ragged and its raycast full of holes). */
  double truncation_voxels = 4.0;
  static constexpr double kMaxTruncationVoxels = 64.0;  ///< truncation_voxels' upper bound
  float max_weight = 100.f;          ///< w_max of §4.1.4
  double min_depth = kMinDepth;      ///< depth measurements outside [min, max] are not fused
  double max_depth = kMaxDepth;
  std::optional<Eigen::AlignedBox3d> bounds;  ///< when set, no block is allocated outside it

  double truncation () const { return voxel_size * truncation_voxels; }
  double blockSize () const { return voxel_size * kBlockSide; }

  /** \brief Throws ParameterError naming the offending field. */
  void validate () const;
};

/** \brief A layer beside the volume with one 32-bit value per voxel under the volume's block
  * ids (the segmentation's labels: segmentation::VoxelLabelLayer::labelValues ()), which
  * raycast () can sample at each ray's hit voxel into RaycastResult::values. blocks[id] holds
  * block id's kBlockVoxels values in voxel order (localVoxelIndex), or is nullptr; blocks
  * beyond blocks.size () and null ones read as 0.
  *
  * Sampled in the raycast, each value is read right after its row with the voxel's colour,
  * its memory fetched while the next rays are cast; a pass over RaycastResult::voxels
  * afterwards waits on memory at every pixel (0.5 ms a frame on the real sequences, a
  * twentieth of the whole loop).
  */
struct VoxelValueLayer
{
  std::vector<const std::uint32_t*> blocks;
};

/** \brief What the volume looks like from a camera (§4.1.5): the model maps V^m and N^m,
  * colours, and the voxel each ray hit, all organized like the camera's image and in
  * that camera's frame. Pixels where the ray hits no surface hold NaN vertices and
  * normals, black and kNoVoxel. Layers beside the TSDF turn the voxel numbers into their
  * own maps (the segmentation's L^m of §4.2.2.1: segmentation::VoxelLabelLayer::labelImage).
  */
struct RaycastResult
{
  PinholeCamera camera;
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity ();  ///< camera-to-world of the view
  cv::Mat vertices;   ///< CV_32FC3, camera frame (metres)
  cv::Mat normals;    ///< CV_32FC3, camera frame, unit, facing the camera
  cv::Mat colors;     ///< CV_8UC3 BGR
  cv::Mat voxels;     ///< CV_32S: VoxelNumber of the voxel nearest each hit (kNoVoxel, i.e. −1, where none)
  /// CV_32S: a sampled VoxelValueLayer's value at each hit voxel (0 where none), when the
  /// raycast was given one; empty otherwise
  cv::Mat values;
  /// CV_8U, set by the depth-hinted raycast: 255 where the hint had a hole and the ray
  /// found no surface (the next raycast may skip searching there, see RaycastHoleSkip)
  cv::Mat empty_holes;

  /** \brief CV_32F z-depth of the vertices (0 where there is no surface). */
  cv::Mat depth () const;
};

/** \brief What a depth-hinted raycast may take from the previous one at a nearby pose: a
  * ray through a hole of the hint, which Newton from the row's last surface did not
  * settle, is searched by a march to the far end of its tile — on Kinect data a fifth
  * of the raycast's time, and four times in five it finds nothing. Where \a empty_holes
  * (RaycastResult::empty_holes of that raycast) says the previous search found nothing,
  * the march is skipped, except on the pixels with (u + v + phase) mod refresh_period
  * = 0, so a surface that appears behind a lasting hole is found within refresh_period
  * frames. Only rays through holes are affected, and only their marches.
  */
struct RaycastHoleSkip
{
  cv::Mat empty_holes;         ///< CV_8U of the image size; empty = search every hole
  unsigned phase = 0;          ///< advanced by one per frame by the caller
  unsigned refresh_period = 8;
};

/** \brief What a raycast may use beyond the camera and the pose (TSDFVolume::raycast). */
struct RaycastOptions
{
  /** A depth map seen from this very pose (CV_32F metres of the image size, e.g. the frame
    * just integrated): rays start two voxels in front of its valid pixels instead of at
    * the nearest block (the full march where that start lies behind a surface), which
    * skips most of the march; model surfaces further in front of the hint (stale geometry
    * the frame no longer sees there) are then not rendered. Empty: no hint. */
  cv::Mat depth_hint;
  /** With a hint: the searches behind holes it marks are skipped (RaycastHoleSkip); its
    * empty_holes must not share data with the result's. */
  RaycastHoleSkip hole_skip;
  /** When given, each hit voxel's value in this layer goes to RaycastResult::values. */
  const VoxelValueLayer* values = nullptr;
};

/** \brief Truncated signed distance volume on sparse voxel hashing (Nießner et al. 2013,
  * InfiniTAM / Kähler et al. 2015): 8³-voxel blocks are allocated only inside the
  * truncation band of observed surfaces, found through a hash of block coordinates.
  * Memory therefore grows with the observed surface, not with the bounding volume.
  *
  * Voxel (i, j, k) is the lattice point (i, j, k) · voxel_size in world coordinates.
  * Each voxel carries a distance, weight and colour (TsdfVoxel); other layers key what they
  * keep per voxel by its number (VoxelNumber: block id and index), which the raycast and
  * the extraction report, so the volume knows nothing of them.
  *
  * The volume holds the algorithms (integrate, raycast, extract, save/load, reset) over a
  * VoxelBlockStore that holds the blocks; readers reach blocks and voxels through store ()
  * (read-only: only the volume's own algorithms write voxels).
  *
  * integrate() and raycast() run their per-block and per-pixel loops in parallel
  * (the project's thread pool, common/parallel.h); the volume is not safe to modify from
  * several threads at once.
  */
class TSDFVolume
{
public:
  using Ptr = std::shared_ptr<TSDFVolume>;
  using ConstPtr = std::shared_ptr<const TSDFVolume>;

  explicit TSDFVolume (const TSDFVolumeConfig& config = TSDFVolumeConfig ());

  const TSDFVolumeConfig& getConfig () const { return config_; }

  /** \brief Fuses one depth map (CV_32F metres, 0/NaN invalid) and its registered colour
    * (CV_8UC3 BGR of the same size, or empty) seen by \a camera at camera-to-world
    * \a pose: allocates the blocks in the band around the measured surface, then updates
    * their voxels by the running average of §4.1.4.
    */
  void
  integrate (const cv::Mat& depth, const cv::Mat& color, const PinholeCamera& camera, const Eigen::Isometry3d& pose);

  /** \brief Renders the model from \a camera at camera-to-world \a pose into \a out
    * (its buffers are reused when their size fits). Rays start and stop at the depth range
    * of the allocated blocks covering each 8×8 tile, skip unallocated blocks a block at a
    * time, and locate the zero crossing by trilinear interpolation; \a options add a depth
    * hint, the hole skip and a value layer to sample (RaycastOptions). Throws
    * cuefusion::Error on a camera or option of the wrong kind.
    */
  void
  raycast (const PinholeCamera& camera, const Eigen::Isometry3d& pose, RaycastResult& out,
           const RaycastOptions& options = RaycastOptions ()) const;

  /** \brief What an extraction writes as each point's label: a function of the number of
    * the voxel nearer the point (e.g. a label layer's lookup), called from several threads
    * at once. Empty: label 0 / no labels.
    */
  using VoxelLabelFunction = std::function<std::uint32_t (VoxelNumber)>;

  /** \brief Surface points: the zero crossings along the x, y and z voxel edges, with
    * interpolated colour and label_of (the nearer voxel); \a normals (when given) gets the
    * normalised TSDF gradient at each point.
    */
  void
  extractPointCloud (pcl::PointCloud<pcl::PointXYZRGBL>& cloud, pcl::PointCloud<pcl::Normal>* normals = nullptr,
                     const VoxelLabelFunction& label_of = {}) const;

  /** \brief Triangle mesh by marching cubes over every allocated block, vertices shared
    * between neighbouring cubes, each with its fused colour, the area-weighted normal of its
    * triangles and, when \a label_of is given, label_of (the voxel nearer it) (labels stay
    * empty otherwise); triangles wind counter-clockwise seen from outside.
    */
  TriangleMesh
  extractTriangleMesh (const VoxelLabelFunction& label_of = {}) const;

  /** \brief extractTriangleMesh () as a pcl::PolygonMesh (io::toPolygonMesh: cloud fields x
    * y z rgba [label] normal_x normal_y normal_z). It takes about three times the memory.
    */
  pcl::PolygonMesh
  extractMesh (const VoxelLabelFunction& label_of = {}) const;

  /** \brief Writes the whole volume (config, blocks, voxels) in a versioned binary format;
    * atomic (temporary file, then rename). Throws cuefusion::Error naming the file.
    */
  void
  save (const std::string& path) const;

  /** \brief Reads a volume written by save(); throws cuefusion::Error naming the file when
    * it is missing, of another format or version, or truncated.
    */
  static TSDFVolume
  load (const std::string& path);

  /** \brief Drops every block (the configuration stays). */
  void
  reset ();

  std::size_t blockCount () const { return store_.size (); }

  /** \brief How far from the origin, along each axis, a camera may be for its whole depth
    * range (max_depth and the truncation band) to lie inside the addressable range of
    * voxel coordinates (kVoxelCoordinateLimit voxels); integrate() refuses a camera
    * beyond it (its frame would be dropped block by block, an empty map unsaid).
    */
  double addressableReach () const;

  /** \brief Whether a camera at \a pose lies within addressableReach() (and is finite). */
  bool reaches (const Eigen::Isometry3d& pose) const;

  /** \brief An identity of the space the volume covers: its voxel size, truncation and the
    * set of its blocks (in any order). Files saved beside a volume (KeyframeDatabase::save)
    * record it, so that they are never loaded with another run's volume.
    */
  std::uint64_t fingerprint () const;

  /** \brief Bytes held by blocks and the hash table. */
  std::size_t memoryUsage () const;

  /** \brief Blocks allocated or updated by the last integrate() call. */
  const std::vector<std::int32_t>& lastIntegratedBlocks () const { return integrated_blocks_; }

  /** \brief When on, integrate() lists the voxels the frame saw inside the truncation band
    * (lastObservedSurface()), for the label update of §4.2.4. Off by default: it costs
    * integration a little and only the segmentation pipeline reads it.
    */
  void setRecordObservedSurface (bool on) { record_observed_ = on; }
  bool getRecordObservedSurface () const { return record_observed_; }

  /** \brief The voxels the last integrate() saw inside the truncation band (see
    * SurfaceObservation), in lists filled by its parallel work items (each voxel appears
    * once); empty when recording is off, after reset() and in a loaded volume.
    */
  const std::vector<std::vector<SurfaceObservation>>& lastObservedSurface () const { return observed_; }

  /** \brief Image size of the last integrate() call (0 × 0 before the first). */
  cv::Size lastIntegratedSize () const { return integrated_size_; }

  /** \brief The blocks and voxels, read-only: blocks and voxels by id or coordinates
    * (VoxelBlockStore::block, findBlock, findVoxel, findVoxelNumber).
    */
  const VoxelBlockStore& store () const { return store_; }

  /** \brief World position of voxel \a v. */
  Eigen::Vector3f
  voxelPosition (const Eigen::Vector3i& v) const
  {
    return v.cast<float> () * static_cast<float> (config_.voxel_size);
  }

private:
  /** \brief Ids of the blocks the band around \a depth touches, allocating missing ones. */
  void
  allocateBlocks (const cv::Mat& depth, const PinholeCamera& camera, const Eigen::Isometry3d& pose);

  TSDFVolumeConfig config_;
  VoxelBlockStore store_;
  std::vector<std::int32_t> integrated_blocks_;
  bool record_observed_ = false;
  std::vector<std::vector<SurfaceObservation>> observed_;  ///< one list per integration work item
  cv::Size integrated_size_;
  std::vector<std::uint32_t> block_stamp_;  ///< frame counter that last listed each block
  std::uint32_t stamp_ = 0;
};
}  // namespace reconstruction
}  // namespace cuefusion
