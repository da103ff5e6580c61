// SPDX-License-Identifier: BSD-3-Clause
#pragma once

#include <cuefusion/common/exceptions.h>

#include <cuefusion/segmentation/surface_planes.h>

#include <pcl/console/print.h>
#include <pcl/pcl_base.h>
#include <pcl/point_cloud.h>

#include <cmath>
#include <limits>
#include <string>
#include <vector>

namespace cuefusion
{
namespace segmentation
{
/** \brief Throws cuefusion::Error, after a PCL_ERROR line, unless \a cloud is a non-empty
  * organized cloud with at least one finite point and \a normals (when given) has the
  * same width and height. \a who names the class in the message.
  */
template <typename PointT, typename PointNT>
void
checkOrganizedInput (const std::string& who, const pcl::PointCloud<PointT>* cloud,
                     const pcl::PointCloud<PointNT>* normals)
{
  std::string problem;
  if (!cloud || cloud->empty ())
    problem = "empty input cloud";
  else if (!cloud->isOrganized () || cloud->height < 2)
    problem = "input cloud is not organized (height " + std::to_string (cloud->height) + ")";
  else if (cloud->size () != static_cast<std::size_t> (cloud->width) * cloud->height)
    problem = "input cloud has " + std::to_string (cloud->size ()) + " points for " + std::to_string (cloud->width) +
              "x" + std::to_string (cloud->height);
  else if (normals && (normals->width != cloud->width || normals->height != cloud->height ||
                       normals->size () != cloud->size ()))
    problem = "normals are " + std::to_string (normals->width) + "x" + std::to_string (normals->height) +
              " but the cloud is " + std::to_string (cloud->width) + "x" + std::to_string (cloud->height);
  else
  {
    bool any_finite = false;
    for (const PointT& p : cloud->points)
      if (std::isfinite (p.z))
      {
        any_finite = true;
        break;
      }
    if (!any_finite)
      problem = "input cloud has no finite point";
  }
  if (!problem.empty ())
  {
    PCL_ERROR ("[cuefusion::%s] %s\n", who.c_str (), problem.c_str ());
    throw Error (who, problem);
  }
}

/** \brief Leaves only the points of \a indices in \a planes: every other point (and its
  * normal) becomes NaN, i.e. missing, as a hole in the depth would be. Throws
  * cuefusion::Error naming \a who for an index outside the planes.
  */
inline void
keepOnlyIndices (const std::string& who, const pcl::Indices& indices, SurfacePlanes& planes)
{
  const std::size_t n = planes.z.size ();
  std::vector<std::uint8_t> keep (n, 0);
  for (const pcl::index_t i : indices)
  {
    if (i < 0 || static_cast<std::size_t> (i) >= n)
    {
      const std::string problem =
        "index " + std::to_string (i) + " is outside the input cloud (" + std::to_string (n) + " points)";
      PCL_ERROR ("[cuefusion::%s] %s\n", who.c_str (), problem.c_str ());
      throw Error (who, problem);
    }
    keep[static_cast<std::size_t> (i)] = 1;
  }
  const float nan = std::numeric_limits<float>::quiet_NaN ();
  for (std::size_t i = 0; i < n; ++i)
    if (!keep[i])
      planes.x[i] = planes.y[i] = planes.z[i] = planes.nx[i] = planes.ny[i] = planes.nz[i] = nan;
}

/** \brief What the organized-cloud classes of this module share (PCL style): the input
  * cloud (pcl::PCLBase), input normals, a validated Config struct, and the checked copy
  * of both into SurfacePlanes that their computations run on.
  */
template <typename PointT, typename PointNT, typename Config>
class OrganizedCloudWithNormals : public pcl::PCLBase<PointT>
{
public:
  using NormalCloudConstPtr = typename pcl::PointCloud<PointNT>::ConstPtr;

  void setInputNormals (const NormalCloudConstPtr& normals) { normals_ = normals; }
  NormalCloudConstPtr getInputNormals () const { return normals_; }

  /** \brief Throws cuefusion::ParameterError for an invalid configuration. */
  void
  setConfig (const Config& config)
  {
    config.validate ();
    config_ = config;
  }
  const Config& getConfig () const { return config_; }

protected:
  /** \brief setConfig of a copy of the config changed by \a change (for the setters). */
  template <typename F>
  void
  updateConfig (F&& change)
  {
    Config config = config_;
    change (config);
    setConfig (config);
  }

  /** \brief Checks the input cloud and normals (cuefusion::Error naming \a who) and copies
    * them into \a planes; with indices (setIndices) only the points they name, every
    * other point is left out as missing.
    */
  void
  toPlanes (const std::string& who, SurfacePlanes& planes) const
  {
    checkOrganizedInput<PointT, PointNT> (who, input_.get (), normals_.get ());
    if (!normals_)
      throw Error (who, "no input normals (setInputNormals)");
    planes.assign (*input_, *normals_);
    if (hasIndices ())
      keepOnlyIndices (who, *indices_, planes);
  }

  /** \brief True after setIndices (pcl::PCLBase keeps "use all points" as fake indices). */
  bool hasIndices () const { return this->use_indices_ && !this->fake_indices_ && indices_; }

  using pcl::PCLBase<PointT>::input_;
  using pcl::PCLBase<PointT>::indices_;
  NormalCloudConstPtr normals_;
  Config config_;
};
}  // namespace segmentation
}  // namespace cuefusion
