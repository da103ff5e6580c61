// SPDX-License-Identifier: BSD-3-Clause
// The PCL peer of `cuefusion segment-frame --drop-support-plane` for scripts/bench: PCL's
// own organized segmentation as its tutorials and organized_segmentation_demo set it up.
//   normals   IntegralImageNormalEstimation (COVARIANCE_MATRIX, smoothing 10, depth change 0.02)
//   planes    OrganizedMultiPlaneSegmentation (≥ 10000 inliers, 3°, 2 cm): every plane removed
//   objects   OrganizedConnectedComponentSegmentation + EuclideanClusterComparator (1 cm,
//             depth dependent) on the remaining points, clusters ≥ 500 points
// Usage: cuefusion_pcl_peer_segmentation IN_DIR OUT_DIR TIMINGS.json
// Writes OUT_DIR/<stem>.pcd (PointXYZRGBL, label 0 = none) per input PCD.
#include <cuefusion/io/map_io.h>

#include <boost/filesystem.hpp>
#include <nlohmann/json.hpp>

#include <pcl/common/time.h>
#include <pcl/features/integral_image_normal.h>
#include <pcl/io/pcd_io.h>
#include <pcl/segmentation/euclidean_cluster_comparator.h>
#include <pcl/segmentation/organized_connected_component_segmentation.h>
#include <pcl/segmentation/organized_multi_plane_segmentation.h>

#include <algorithm>
#include <fstream>
#include <iostream>

namespace fs = boost::filesystem;
using Point = pcl::PointXYZRGBA;

int
main (int argc, char** argv)
{
  if (argc != 4)
  {
    std::cerr << "usage: cuefusion_pcl_peer_segmentation IN_DIR OUT_DIR TIMINGS.json\n";
    return 2;
  }
  pcl::console::setVerbosityLevel (pcl::console::L_ALWAYS);
  std::vector<fs::path> inputs;
  for (fs::directory_iterator it (argv[1]), end; it != end; ++it)
    if (it->path ().extension () == ".pcd")
      inputs.push_back (it->path ());
  std::sort (inputs.begin (), inputs.end ());
  fs::create_directories (argv[2]);
  nlohmann::json frames = nlohmann::json::array ();
  for (const fs::path& path : inputs)
  {
    pcl::PointCloud<Point>::Ptr cloud (new pcl::PointCloud<Point>);
    if (pcl::io::loadPCDFile (path.string (), *cloud) < 0 || !cloud->isOrganized ())
    {
      std::cerr << path.string () << ": cannot read an organized PCD\n";
      return 1;
    }
    pcl::StopWatch watch;
    pcl::PointCloud<pcl::Normal>::Ptr normals (new pcl::PointCloud<pcl::Normal>);
    pcl::IntegralImageNormalEstimation<Point, pcl::Normal> ne;
    ne.setNormalEstimationMethod (ne.COVARIANCE_MATRIX);
    ne.setMaxDepthChangeFactor (0.02f);
    ne.setNormalSmoothingSize (10.f);
    ne.setInputCloud (cloud);
    ne.compute (*normals);
    const double normals_ms = watch.getTime ();

    watch.reset ();
    pcl::OrganizedMultiPlaneSegmentation<Point, pcl::Normal, pcl::Label> mps;
    mps.setMinInliers (10000);
    mps.setAngularThreshold (3.0 * M_PI / 180.0);
    mps.setDistanceThreshold (0.02);
    mps.setInputNormals (normals);
    mps.setInputCloud (cloud);
    std::vector<pcl::PlanarRegion<Point>, Eigen::aligned_allocator<pcl::PlanarRegion<Point>>> regions;
    std::vector<pcl::ModelCoefficients> coefficients;
    std::vector<pcl::PointIndices> inliers, boundary;
    pcl::PointCloud<pcl::Label>::Ptr plane_labels (new pcl::PointCloud<pcl::Label>);
    std::vector<pcl::PointIndices> label_indices;
    mps.segmentAndRefine (regions, coefficients, inliers, plane_labels, label_indices, boundary);
    const double planes_ms = watch.getTime ();

    watch.reset ();
    // Plane points become NaN for the clustering (EuclideanClusterComparator's label
    // exclusion behaves as an allow-list in PCL 1.13, so it is not used).
    pcl::PointCloud<Point>::Ptr rest (new pcl::PointCloud<Point> (*cloud));
    for (const pcl::PointIndices& plane : inliers)
      for (const int i : plane.indices)
        (*rest)[i].x = (*rest)[i].y = (*rest)[i].z = std::numeric_limits<float>::quiet_NaN ();
    pcl::EuclideanClusterComparator<Point, pcl::Label>::Ptr comparator (new pcl::EuclideanClusterComparator<Point, pcl::Label>);
    comparator->setInputCloud (rest);
    comparator->setDistanceThreshold (0.01f, true);
    pcl::PointCloud<pcl::Label> cluster_labels;
    std::vector<pcl::PointIndices> clusters;
    pcl::OrganizedConnectedComponentSegmentation<Point, pcl::Label> components (comparator);
    components.setInputCloud (rest);
    components.segment (cluster_labels, clusters);
    const double clusters_ms = watch.getTime ();

    pcl::PointCloud<pcl::PointXYZRGBL> out (cloud->width, cloud->height);
    for (std::size_t i = 0; i < cloud->size (); ++i)
    {
      out[i].getVector3fMap () = (*cloud)[i].getVector3fMap ();
      out[i].rgba = (*cloud)[i].rgba;
      out[i].label = 0;
    }
    std::uint32_t next = 1;
    for (const pcl::PointIndices& cluster : clusters)
      if (cluster.indices.size () >= 500)
      {
        for (const int i : cluster.indices)
          out[i].label = next;
        ++next;
      }
    cuefusion::io::saveMapPCD ((fs::path (argv[2]) / path.filename ()).string (), out);
    frames.push_back ({{"input", path.string ()}, {"normals_ms", normals_ms}, {"planes_ms", planes_ms},
                       {"clusters_ms", clusters_ms}, {"segmentation_ms", normals_ms + planes_ms + clusters_ms},
                       {"segments", next - 1}});
  }
  std::ofstream (argv[3]) << nlohmann::json ({{"frames", frames}}).dump (1) << "\n";
  return 0;
}
