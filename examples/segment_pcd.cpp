// SPDX-License-Identifier: BSD-3-Clause
// A PCL filter chain with cuefusion's geometric segmentation in the middle:
//   load an organized PCD → PassThrough picks the points nearer than MAX_DEPTH (indices)
//   → cuefusion::segmentation::GeometricSegmentation on those indices (it smooths the
//   depth and finds normals as `cuefusion segment-frame` does: on raw sensor depth it
//   gives that command's segments) → PCL ExtractIndices cuts out each segment → one PCD
//   per segment and the whole cloud with a label field (pcl_viewer, press 'l' for labels).
//
// usage: segment_pcd INPUT.pcd OUT_DIR [MAX_DEPTH_M [MIN_POINTS]]

#include <cuefusion/common/exceptions.h>
#include <cuefusion/segmentation/geometric_segmentation.h>

#include <pcl/filters/extract_indices.h>
#include <pcl/filters/passthrough.h>
#include <pcl/io/pcd_io.h>
#include <pcl/point_types.h>

#include <cstdio>
#include <cstdlib>
#include <iostream>
#include <string>
#include <vector>

using PointT = pcl::PointXYZRGBA;

int
main (int argc, char** argv)
{
  if (argc < 3)
  {
    std::cerr << "usage: segment_pcd INPUT.pcd OUT_DIR [MAX_DEPTH_M [MIN_POINTS]]\n";
    return 2;
  }
  const std::string input = argv[1], out_dir = argv[2];
  const float max_depth = argc > 3 ? std::strtof (argv[3], nullptr) : 3.f;
  const std::size_t min_points = argc > 4 ? std::strtoul (argv[4], nullptr, 10) : 500;

  pcl::PointCloud<PointT>::Ptr cloud (new pcl::PointCloud<PointT>);
  if (pcl::io::loadPCDFile (input, *cloud) != 0 || !cloud->isOrganized ())
  {
    std::cerr << "segment_pcd: " << input << ": cannot read an organized PCD\n";
    return 1;
  }

  // A region of interest as indices: the points nearer than max_depth.
  pcl::IndicesPtr near (new pcl::Indices);
  pcl::PassThrough<PointT> pass;
  pass.setInputCloud (cloud);
  pass.setFilterFieldName ("z");
  pass.setFilterLimits (0.f, max_depth);
  pass.filter (*near);

  // cuefusion's segmentation, PCL style: labels and the points of each label.
  pcl::PointCloud<pcl::PointXYZRGBL> labelled;
  std::vector<pcl::PointIndices> label_indices;
  cuefusion::segmentation::GeometricSegmentation<PointT, pcl::Normal> segmentation;
  segmentation.setInputCloud (cloud);  // raw depth: the segmentation preprocesses it
  segmentation.setIndices (near);
  try
  {
    segmentation.segment (labelled, label_indices);
  }
  catch (const cuefusion::Error& e)
  {
    std::cerr << "segment_pcd: " << e.what () << "\n";
    return 1;
  }

  // One cloud per segment with PCL's ExtractIndices (label 0 = in no segment).
  pcl::ExtractIndices<PointT> extract;
  extract.setInputCloud (cloud);
  pcl::PCDWriter writer;
  std::size_t written = 0;
  for (std::size_t label = 1; label < label_indices.size (); ++label)
  {
    if (label_indices[label].indices.size () < min_points)
      continue;
    pcl::PointCloud<PointT> segment;
    extract.setIndices (pcl::make_shared<const pcl::PointIndices> (label_indices[label]));
    extract.filter (segment);
    char name[64];
    std::snprintf (name, sizeof (name), "/segment_%03zu.pcd", label);
    if (writer.writeBinaryCompressed (out_dir + name, segment) != 0)
    {
      std::cerr << "segment_pcd: cannot write " << out_dir << name << "\n";
      return 1;
    }
    ++written;
  }
  if (writer.writeBinaryCompressed (out_dir + "/labelled.pcd", labelled) != 0)
  {
    std::cerr << "segment_pcd: cannot write " << out_dir << "/labelled.pcd\n";
    return 1;
  }
  std::cout << input << ": " << near->size () << " points nearer than " << max_depth << " m, "
            << segmentation.getSegmentCount () << " segments, " << written << " with at least " << min_points
            << " points written to " << out_dir << "\n";
  return 0;
}
