// SPDX-License-Identifier: BSD-3-Clause
// The README's segmentation snippet as a program (test/install/check_install.sh builds it
// against an installed cuefusion): the lines between the two markers below are replaced by
// the README's own, so the test compiles what the README prints. Usage: myapp FRAME.pcd,
// a PointXYZRGBL cloud segment-frame wrote: its xyz are segmented by the snippet and the
// labels compared with segment-frame's, up to renumbering.
// ---- before the snippet
#include <cuefusion/segmentation/geometric_segmentation.h>

#include <pcl/io/pcd_io.h>
#include <pcl/point_types.h>

#include <iostream>
#include <map>
#include <vector>

int
main (int argc, char** argv)
{
  if (argc != 2)
  {
    std::cerr << "usage: myapp SEGMENT_FRAME_OUTPUT.pcd\n";
    return 2;
  }
  pcl::PointCloud<pcl::PointXYZRGBL> reference;
  if (pcl::io::loadPCDFile (argv[1], reference) != 0)
    return 1;
  auto cloud = pcl::make_shared<pcl::PointCloud<pcl::PointXYZRGBA>> ();
  pcl::io::loadPCDFile (argv[1], *cloud);  // the same points, without the labels
  auto roi = pcl::make_shared<pcl::Indices> ();
  for (std::size_t i = 0; i < cloud->size (); ++i)
    roi->push_back (static_cast<int> (i));
// ---- the snippet (replaced by the README's lines)
  cuefusion::segmentation::GeometricSegmentation<pcl::PointXYZRGBA, pcl::Normal> segmentation;
  segmentation.setInputCloud (cloud);
  segmentation.setIndices (roi);
  pcl::PointCloud<pcl::PointXYZRGBL> labels;
  std::vector<pcl::PointIndices> label_indices;
  segmentation.segment (labels, label_indices);
// ---- after the snippet
  // Same segments up to renumbering: one-to-one between the two label sets, 0 with 0.
  std::map<std::uint32_t, std::uint32_t> forward, backward;
  std::size_t differ = 0;
  for (std::size_t i = 0; i < reference.size (); ++i)
  {
    const std::uint32_t a = labels[i].label, b = reference[i].label;
    const auto f = forward.emplace (a, b).first;
    const auto g = backward.emplace (b, a).first;
    if (f->second != b || g->second != a || (a == 0) != (b == 0))
      ++differ;
  }
  std::cout << "README snippet: " << label_indices.size () << " labels, segment-frame: " << backward.size ()
            << " labels; " << differ << " points differ\n";
  return differ == 0 ? 0 : 1;
}
