// SPDX-License-Identifier: BSD-3-Clause
#pragma once
// What pcl_viewer needs to colour a cuefusion PCD by segment: PCL reads the file back
// with x, y, z, a colour field and a label field of one uint32 (pcl_viewer offers every
// field as a colour handler; 'l' lists them).

#include <pcl/PCLPointCloud2.h>
#include <pcl/conversions.h>
#include <pcl/io/pcd_io.h>
#include <pcl/point_types.h>

#include <gtest/gtest.h>

#include <set>
#include <string>

namespace cuefusion
{
namespace test
{
inline void
expectLabelledPCD (const std::string& path, std::size_t min_segments)
{
  pcl::PCLPointCloud2 blob;
  ASSERT_EQ (pcl::io::loadPCDFile (path, blob), 0) << path;
  auto field = [&] (const std::string& name) -> const pcl::PCLPointField* {
    for (const pcl::PCLPointField& f : blob.fields)
      if (f.name == name)
        return &f;
    return nullptr;
  };
  for (const char* name : {"x", "y", "z"})
  {
    const pcl::PCLPointField* f = field (name);
    ASSERT_NE (f, nullptr) << path << " has no " << name;
    EXPECT_EQ (f->datatype, pcl::PCLPointField::FLOAT32) << path << ": " << name;
  }
  EXPECT_TRUE (field ("rgb") || field ("rgba")) << path << " has no colour";
  const pcl::PCLPointField* label = field ("label");
  ASSERT_NE (label, nullptr) << path << " has no label field";
  EXPECT_EQ (label->datatype, pcl::PCLPointField::UINT32) << path;
  EXPECT_EQ (label->count, 1u) << path;
  pcl::PointCloud<pcl::PointXYZRGBL> cloud;
  pcl::fromPCLPointCloud2 (blob, cloud);
  std::set<std::uint32_t> labels;
  for (const pcl::PointXYZRGBL& p : cloud)
    if (p.label != 0)
      labels.insert (p.label);
  EXPECT_GE (labels.size (), min_segments) << path;
}
}  // namespace test
}  // namespace cuefusion
