// SPDX-License-Identifier: BSD-3-Clause
#pragma once

#include <cuefusion/common/rgbd_frame.h>
#include <cuefusion/common/sensor_defaults.h>
#include <cuefusion/simulation/scene_renderer.h>
#include <cuefusion/io/sequence_writer.h>
#include <cuefusion/simulation/simulated_detector.h>
#include <cuefusion/simulation/synthetic_scene.h>

#include <pcl/point_cloud.h>
#include <pcl/point_types.h>

#include <cstdint>
#include <functional>
#include <string>

namespace cuefusion
{
namespace simulation
{
/** \brief How to turn a scene into a sequence. */
struct SyntheticSequenceConfig
{
  std::size_t frames = 60;
  double fps = kFrameRate;
  std::uint64_t seed = 1;
  int width = 0;                     ///< 0 = the scene's camera; else scaled to this size
  int height = 0;
  DepthNoiseConfig noise;            ///< off by default: exact depth
  DetectorErrorConfig detector;      ///< perfect detector by default
  double gt_cloud_spacing = 0.01;    ///< metres between ground-truth cloud points
  /** writeSyntheticSequence's gt_cloud.pcd holds only the surface some frame measured
    * (markObserved: the pixel shows the point's object with a depth, and the point lies on
    * the surface seen there), as ScanNet's annotations lie on the reconstructed mesh: the
    * back of a cabinet, a ceiling the camera never faced or a counter lost at grazing
    * angles is no instance point a map could have. false: every surface point
    * (groundTruthCloud). */
  bool gt_observed_only = true;

  void validate () const;
};

/** \brief The points of a cloud grouped by cubes of space (SyntheticSequence::cloudCells),
  * for markObserved to pass over the cubes a view cannot see. */
struct CloudCells
{
  static constexpr float kSide = 0.25f;     ///< metres: the side of a cube
  std::vector<std::uint32_t> points;       ///< the cloud's indices, cube by cube
  std::vector<std::uint32_t> begin;        ///< cube k holds points[begin[k]] … points[begin[k + 1] − 1]
  std::vector<Eigen::Vector3f> centre;     ///< cube k's centre
  std::size_t cloud_size = 0;              ///< the size of the cloud they were made of
};

/** \brief A synthetic RGB-D sequence with exact truth: frame i is the scene seen from
  * the orbit at s = i / (frames − 1), with its pose, instance and class masks.
  */
class SyntheticSequence
{
public:
  SyntheticSequence (const SyntheticScene& scene, const SyntheticSequenceConfig& config);

  std::size_t size () const { return config_.frames; }
  const PinholeCamera& camera () const { return camera_; }
  const SyntheticScene& scene () const { return scene_; }
  const SyntheticSequenceConfig& config () const { return config_; }

  Eigen::Isometry3d poseAt (std::size_t i) const;
  /** \brief Renders frame \a i (deterministic for a given seed). */
  RGBDFrame::Ptr frame (std::size_t i) const;
  /** \brief Frame \a i as the renderer gives it (exact depth and normals too). */
  RenderedView render (std::size_t i) const;
  /** \brief Frame \a i from its rendered \a view (render (i)). */
  RGBDFrame::Ptr frame (std::size_t i, const RenderedView& view) const;
  /** \brief The simulated detector's output on a rendered frame. */
  DetectionResult detections (const RGBDFrame& frame) const;
  /** \brief Every visible-from-outside surface point, labelled with its object id. */
  pcl::PointCloud<pcl::PointXYZRGBL>::Ptr groundTruthCloud () const;
  /** \brief Sets observed[k] for each point of \a cloud that view \a i of this sequence
    * (render (i)) measured: the pixel it projects to shows its object with a depth
    * (not dropped), and the point lies within 5 mm of the surface seen there (the plane
    * through the pixel's exact point and normal, so a slanted surface counts whole and
    * the far side of a 2 cm board does not). \a observed has the cloud's size.
    * \a cells, when given, is cloudCells (cloud): the cubes of space out of the view's
    * frustum are passed over whole (the same flags, far less work for a large cloud). */
  void markObserved (const pcl::PointCloud<pcl::PointXYZRGBL>& cloud, std::size_t i, const RenderedView& view,
                     std::vector<char>& observed, const CloudCells* cells = nullptr) const;
  /** \brief The points of \a cloud grouped by the cube of side CloudCells::kSide they lie in. */
  static CloudCells cloudCells (const pcl::PointCloud<pcl::PointXYZRGBL>& cloud);

private:
  SyntheticScene scene_;
  SyntheticSequenceConfig config_;
  PinholeCamera camera_;
  SceneRenderer renderer_;
  SimulatedDetector detector_;
};

/** \brief Writes a whole synthetic sequence into \a dir in \a layout, plus
  * detections/<frame>.png + .json (simulated detector), gt_cloud.pcd (PointXYZRGBL) and
  * scene.json (instances and classes). Everything goes to a temporary sibling folder
  * that is renamed to \a dir at the end, so \a dir is never left half-written; an
  * existing non-empty \a dir is an error unless \a overwrite.
  * \a progress is called with the number of frames written.
  */
void
writeSyntheticSequence (const SyntheticSequence& sequence, io::DatasetLayout layout, const std::string& dir,
                        bool overwrite = false, const std::function<void (std::size_t)>& progress = {});
}  // namespace simulation
}  // namespace cuefusion
