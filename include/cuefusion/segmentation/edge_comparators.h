// SPDX-License-Identifier: BSD-3-Clause
#pragma once

#include <cuefusion/segmentation/concavity_edge_estimation.h>
#include <cuefusion/segmentation/depth_discontinuity_edge_estimation.h>
#include <cuefusion/segmentation/geometric_segmentation.h>
#include <cuefusion/segmentation/organized_input.h>
#include <cuefusion/segmentation/surface_planes.h>

#include <opencv2/core.hpp>

#include <pcl/segmentation/comparator.h>

#include <cmath>
#include <cstdint>
#include <memory>
#include <vector>

namespace cuefusion
{
namespace segmentation
{
/** \brief The edge tests of §4.2.1.1 as a pcl::Comparator, for
  * pcl::OrganizedConnectedComponentSegmentation: two neighbouring points belong together
  * when neither lies on an edge (and both have a point with z > 0). The edge map is
  * computed once per input, on the first compare() after setInputCloud or
  * setInputNormals, with the same code as the estimation classes; so the connected
  * components are GeometricSegmentation's segments before its closings, small-segment
  * removal and edge assignment (each edge point is a component of its own).
  *
  * \code
  * auto comparator = std::make_shared<GeometricEdgeComparator<pcl::PointXYZRGBA, pcl::Normal>> ();
  * comparator->setInputCloud (cloud);
  * comparator->setInputNormals (normals);
  * pcl::OrganizedConnectedComponentSegmentation<pcl::PointXYZRGBA, pcl::Label> components (comparator);
  * components.setInputCloud (cloud);
  * components.segment (labels, label_indices);
  * \endcode
  *
  * Subclasses say which edges count (computeEdges). compare() is const but fills the
  * edge map on first use: one comparator serves one segmentation at a time.
  */
template <typename PointT, typename PointNT>
class EdgeMapComparator : public pcl::Comparator<PointT>
{
public:
  using PointCloudConstPtr = typename pcl::Comparator<PointT>::PointCloudConstPtr;
  using NormalCloudConstPtr = typename pcl::PointCloud<PointNT>::ConstPtr;
  using Ptr = std::shared_ptr<EdgeMapComparator>;
  using ConstPtr = std::shared_ptr<const EdgeMapComparator>;

  void
  setInputCloud (const PointCloudConstPtr& cloud) override
  {
    this->input_ = cloud;
    joinable_.clear ();
  }

  void
  setInputNormals (const NormalCloudConstPtr& normals)
  {
    normals_ = normals;
    joinable_.clear ();
  }
  NormalCloudConstPtr getInputNormals () const { return normals_; }

  bool
  compare (int idx1, int idx2) const override
  {
    if (joinable_.empty ())
      update ();
    return joinable_[static_cast<std::size_t> (idx1)] && joinable_[static_cast<std::size_t> (idx2)];
  }

  /** \brief The edge map of the current input (CV_8U, 1 = edge), computed if needed.
    * Throws cuefusion::Error on unorganized, empty or all-NaN input and on missing
    * normals or normals of another size.
    */
  const cv::Mat&
  getEdges () const
  {
    if (joinable_.empty ())
      update ();
    return edges_;
  }

protected:
  /** \brief Edge map (CV_8U, 1 = edge, planes' size) of \a planes. */
  virtual void computeEdges (const SurfacePlanes& planes, cv::Mat& edges) const = 0;

  /** \brief Name in error messages. */
  virtual const char* name () const = 0;

  void
  update () const
  {
    checkOrganizedInput<PointT, PointNT> (name (), this->input_.get (), normals_.get ());
    if (!normals_)
      throw Error (name (), "no input normals (setInputNormals)");
    SurfacePlanes planes;
    planes.assign (*this->input_, *normals_);
    computeEdges (planes, edges_);
    joinable_.assign (planes.z.size (), 0);
    for (std::size_t i = 0; i < joinable_.size (); ++i)
      joinable_[i] = std::isfinite (planes.z[i]) && edges_.data[i] == 0;
  }

  NormalCloudConstPtr normals_;
  mutable cv::Mat edges_;
  mutable std::vector<std::uint8_t> joinable_;  ///< empty = not computed for this input
};

/** \brief An EdgeMapComparator with a validated Config struct of its edge test. */
template <typename PointT, typename PointNT, typename Config>
class ConfiguredEdgeComparator : public EdgeMapComparator<PointT, PointNT>
{
public:
  /** \brief Throws cuefusion::ParameterError for an invalid configuration. */
  explicit ConfiguredEdgeComparator (const Config& config) { setConfig (config); }

  /** \brief Throws cuefusion::ParameterError for an invalid configuration. */
  void
  setConfig (const Config& config)
  {
    config.validate ();
    config_ = config;
    this->joinable_.clear ();
  }
  const Config& getConfig () const { return config_; }

protected:
  Config config_;
};

/** \brief Concave edges only (ConcavityEdgeEstimation's test) as a pcl::Comparator. */
template <typename PointT, typename PointNT>
class ConcavityEdgeComparator : public ConfiguredEdgeComparator<PointT, PointNT, ConcavityEdgeEstimationConfig>
{
public:
  using Ptr = std::shared_ptr<ConcavityEdgeComparator>;
  using ConstPtr = std::shared_ptr<const ConcavityEdgeComparator>;

  explicit ConcavityEdgeComparator (const ConcavityEdgeEstimationConfig& config = ConcavityEdgeEstimationConfig ())
    : ConfiguredEdgeComparator<PointT, PointNT, ConcavityEdgeEstimationConfig> (config)
  {
  }

protected:
  void
  computeEdges (const SurfacePlanes& planes, cv::Mat& edges) const override
  {
    cv::Mat phi;
    computeConcavityMap (planes, this->config_.neighbour_step, this->config_.convexity_test, phi);
    concavityEdges (planes, phi, this->config_, edges);
  }
  const char* name () const override { return "ConcavityEdgeComparator"; }
};

/** \brief Depth-discontinuity edges only (DepthDiscontinuityEdgeEstimation's test) as a
  * pcl::Comparator.
  */
template <typename PointT, typename PointNT>
class DepthDiscontinuityEdgeComparator : public ConfiguredEdgeComparator<PointT, PointNT, DepthDiscontinuityEdgeEstimationConfig>
{
public:
  using Ptr = std::shared_ptr<DepthDiscontinuityEdgeComparator>;
  using ConstPtr = std::shared_ptr<const DepthDiscontinuityEdgeComparator>;

  explicit DepthDiscontinuityEdgeComparator (const DepthDiscontinuityEdgeEstimationConfig& config = DepthDiscontinuityEdgeEstimationConfig ())
    : ConfiguredEdgeComparator<PointT, PointNT, DepthDiscontinuityEdgeEstimationConfig> (config)
  {
  }

protected:
  void
  computeEdges (const SurfacePlanes& planes, cv::Mat& edges) const override
  {
    cv::Mat gamma;
    computeDiscontinuityMap (planes, this->config_.neighbour_step, gamma);
    discontinuityEdges (planes, gamma, this->config_.noise_factor, edges);
  }
  const char* name () const override { return "DepthDiscontinuityEdgeComparator"; }
};

/** \brief Both edge tests as GeometricSegmentation combines them (its config's
  * use_concavity_edges / use_discontinuity_edges; the labelling part of the config is
  * not used) as a pcl::Comparator.
  */
template <typename PointT, typename PointNT>
class GeometricEdgeComparator : public ConfiguredEdgeComparator<PointT, PointNT, GeometricSegmentationConfig>
{
public:
  using Ptr = std::shared_ptr<GeometricEdgeComparator>;
  using ConstPtr = std::shared_ptr<const GeometricEdgeComparator>;

  explicit GeometricEdgeComparator (const GeometricSegmentationConfig& config = GeometricSegmentationConfig ())
    : ConfiguredEdgeComparator<PointT, PointNT, GeometricSegmentationConfig> (config)
  {
  }

protected:
  void
  computeEdges (const SurfacePlanes& planes, cv::Mat& edges) const override
  {
    cv::Mat concave, depth_edges;
    computeGeometricEdges (planes, this->config_, concave, depth_edges);
    cv::bitwise_or (concave, depth_edges, edges);
  }
  const char* name () const override { return "GeometricEdgeComparator"; }
};
}  // namespace segmentation
}  // namespace cuefusion
