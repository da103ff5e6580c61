#pragma once

#include <cuefusion/common/exceptions.h>

#include <pcl/console/print.h>
#include <pcl/point_cloud.h>

#include <cmath>
#include <string>

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
}  // namespace segmentation
}  // namespace cuefusion
