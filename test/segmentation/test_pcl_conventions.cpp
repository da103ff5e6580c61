// SPDX-License-Identifier: BSD-3-Clause
// The segmentation classes as other PCL applications use them: setIndices, segment
// (labels, label_indices) with any label point type, and the edge tests as pcl::Comparators
// for pcl::OrganizedConnectedComponentSegmentation. Ground truth: rendered views and the
// same computation on a cloud whose points outside the indices are removed (NaN).

#include "segmentation/segmentation_fixtures.h"

#include <cuefusion/common/exceptions.h>
#include <cuefusion/segmentation/concavity_edge_estimation.h>
#include <cuefusion/segmentation/depth_discontinuity_edge_estimation.h>
#include <cuefusion/segmentation/edge_comparators.h>
#include <cuefusion/segmentation/geometric_segmentation.h>
#include <cuefusion/segmentation/instance_guided_region_merge.h>
#include <cuefusion/segmentation/support_plane_removal.h>

#include <pcl/common/io.h>
#include <pcl/segmentation/organized_connected_component_segmentation.h>

#include <gtest/gtest.h>

#include <limits>
#include <map>
#include <set>

namespace cuefusion
{
namespace test
{
namespace
{
using Segmentation = segmentation::GeometricSegmentation<pcl::PointXYZ, pcl::Normal>;

/** These tests give the smoothed cloud and its normals (segmentScene): segmented as given. */
segmentation::GeometricSegmentationConfig
asGiven (segmentation::GeometricSegmentationConfig config = segmentation::GeometricSegmentationConfig ())
{
  config.preprocess = false;
  return config;
}

/** The view's pixels inside a rectangle that cuts through both boxes and the table. */
pcl::IndicesPtr
roiIndices (const pcl::PointCloud<pcl::PointXYZ>& cloud)
{
  pcl::IndicesPtr indices (new pcl::Indices);
  for (int y = 120; y < 400; ++y)
    for (int x = 300; x < 600; ++x)
      indices->push_back (static_cast<pcl::index_t> (y * static_cast<int> (cloud.width) + x));
  return indices;
}

std::vector<std::uint8_t>
insideMask (const pcl::PointCloud<pcl::PointXYZ>& cloud, const pcl::Indices& indices)
{
  std::vector<std::uint8_t> inside (cloud.size (), 0);
  for (const pcl::index_t i : indices)
    inside[static_cast<std::size_t> (i)] = 1;
  return inside;
}

/** \a cloud with every point outside \a indices made NaN (what setIndices must mean). */
pcl::PointCloud<pcl::PointXYZ>::Ptr
maskedCloud (const pcl::PointCloud<pcl::PointXYZ>& cloud, const pcl::Indices& indices)
{
  pcl::PointCloud<pcl::PointXYZ>::Ptr masked (new pcl::PointCloud<pcl::PointXYZ> (cloud));
  const auto inside = insideMask (cloud, indices);
  const float nan = std::numeric_limits<float>::quiet_NaN ();
  for (std::size_t i = 0; i < masked->size (); ++i)
    if (!inside[i])
      (*masked)[i].x = (*masked)[i].y = (*masked)[i].z = nan;
  masked->is_dense = false;
  return masked;
}

template <typename PointLT>
std::vector<std::uint32_t>
labelsOf (const pcl::PointCloud<PointLT>& cloud)
{
  std::vector<std::uint32_t> labels;
  for (const PointLT& p : cloud)
    labels.push_back (p.label);
  return labels;
}
}  // namespace

TEST (PclConventions, GeometricSegmentationWithIndicesSegmentsOnlyThosePoints)
{
  const auto s = segmentScene (kTwoBoxes, kObliqueEye, kTableTarget, true);
  const pcl::IndicesPtr indices = roiIndices (*s.smoothed);
  const auto inside = insideMask (*s.smoothed, *indices);

  Segmentation with_indices (asGiven ());
  with_indices.setInputCloud (s.smoothed);
  with_indices.setInputNormals (s.normals);
  with_indices.setIndices (indices);
  pcl::PointCloud<pcl::Label> labels;
  std::vector<pcl::PointIndices> label_indices;
  with_indices.segment (labels, label_indices);
  ASSERT_EQ (labels.size (), s.smoothed->size ());
  ASSERT_EQ (labels.width, s.smoothed->width);
  ASSERT_GE (with_indices.getSegmentCount (), 3);  // the table and both boxes reach into the rectangle
  std::size_t labelled_inside = 0;
  for (std::size_t i = 0; i < labels.size (); ++i)
  {
    if (!inside[i])
    {
      ASSERT_EQ (labels[i].label, 0u) << "point " << i << " lies outside the indices";
    }
    else if (labels[i].label != 0)
      ++labelled_inside;
  }
  EXPECT_GT (labelled_inside, indices->size () / 2);

  // setIndices means exactly "the other points are missing".
  Segmentation masked (asGiven ());
  masked.setInputCloud (maskedCloud (*s.smoothed, *indices));
  masked.setInputNormals (s.normals);
  pcl::PointCloud<pcl::Label> masked_labels;
  masked.segment (masked_labels);
  EXPECT_EQ (labelsOf (labels), labelsOf (masked_labels));

  // Without indices the whole view is segmented (the rectangle is not a default).
  Segmentation whole (asGiven ());
  whole.setInputCloud (s.smoothed);
  whole.setInputNormals (s.normals);
  pcl::PointCloud<pcl::Label> whole_labels;
  whole.segment (whole_labels);
  std::size_t labelled_outside = 0;
  for (std::size_t i = 0; i < whole_labels.size (); ++i)
    labelled_outside += (!inside[i] && whole_labels[i].label != 0) ? 1 : 0;
  EXPECT_GT (labelled_outside, 10000u);
}

TEST (PclConventions, LabelIndicesAgreeWithTheLabelCloud)
{
  const auto s = segmentScene (kTwoBoxes, kObliqueEye, kTableTarget, true);
  Segmentation segmentation (asGiven ());
  segmentation.setInputCloud (s.smoothed);
  segmentation.setInputNormals (s.normals);
  pcl::PointCloud<pcl::Label> labels;
  std::vector<pcl::PointIndices> label_indices;
  segmentation.segment (labels, label_indices);
  const int n = segmentation.getSegmentCount ();
  ASSERT_GE (n, 3);
  ASSERT_EQ (label_indices.size (), static_cast<std::size_t> (n) + 1);
  std::set<pcl::index_t> seen;
  for (std::size_t l = 0; l < label_indices.size (); ++l)
  {
    if (l > 0)
    {
      EXPECT_FALSE (label_indices[l].indices.empty ()) << "segment " << l;
    }
    for (const pcl::index_t i : label_indices[l].indices)
    {
      ASSERT_EQ (labels[static_cast<std::size_t> (i)].label, l);
      ASSERT_TRUE (seen.insert (i).second) << "point " << i << " listed twice";
    }
  }
  // Every labelled point is listed; unlabelled ones only when they have a point.
  for (std::size_t i = 0; i < labels.size (); ++i)
  {
    const bool finite = std::isfinite ((*s.smoothed)[i].z);
    EXPECT_EQ (seen.count (static_cast<pcl::index_t> (i)) == 1, labels[i].label != 0 || finite) << "point " << i;
  }
  EXPECT_FALSE (label_indices[0].indices.empty ());  // edge pixels that no segment took (depth jumps)
}

TEST (PclConventions, LabelPointTypesWithCoordinatesCarryTheInputPoints)
{
  const auto s = segmentScene (kTwoBoxes, kObliqueEye, kTableTarget, true);
  pcl::PointCloud<pcl::PointXYZRGBA>::Ptr coloured (new pcl::PointCloud<pcl::PointXYZRGBA>);
  pcl::copyPointCloud (*s.smoothed, *coloured);
  for (int y = 0; y < s.view.color.rows; ++y)
    for (int x = 0; x < s.view.color.cols; ++x)
    {
      const cv::Vec3b bgr = s.view.color.at<cv::Vec3b> (y, x);
      pcl::PointXYZRGBA& p = (*coloured) (x, y);
      p.b = bgr[0];
      p.g = bgr[1];
      p.r = bgr[2];
      p.a = 255;
    }
  segmentation::GeometricSegmentation<pcl::PointXYZRGBA, pcl::Normal> segmentation (asGiven ());
  segmentation.setInputCloud (coloured);
  segmentation.setInputNormals (s.normals);
  pcl::PointCloud<pcl::Label> plain;
  pcl::PointCloud<pcl::PointXYZRGBL> labelled;
  pcl::PointCloud<pcl::PointXYZL> xyzl;
  segmentation.segment (plain);
  segmentation.segment (labelled);
  segmentation.segment (xyzl);
  EXPECT_EQ (labelsOf (plain), labelsOf (labelled));
  EXPECT_EQ (labelsOf (plain), labelsOf (xyzl));
  ASSERT_EQ (labelled.width, coloured->width);
  ASSERT_EQ (labelled.height, coloured->height);
  for (std::size_t i = 0; i < labelled.size (); i += 97)
  {
    const pcl::PointXYZRGBA& in = (*coloured)[i];
    if (!std::isfinite (in.z))
    {
      EXPECT_FALSE (std::isfinite (labelled[i].z));
      continue;
    }
    EXPECT_EQ (labelled[i].getVector3fMap (), in.getVector3fMap ());
    EXPECT_EQ (xyzl[i].getVector3fMap (), in.getVector3fMap ());
    EXPECT_EQ (labelled[i].r, in.r);
    EXPECT_EQ (labelled[i].g, in.g);
    EXPECT_EQ (labelled[i].b, in.b);
  }
}

TEST (PclConventions, EdgeEstimationsAndSupportPlaneRemovalHonourIndices)
{
  const auto s = segmentScene (kTwoBoxes, kObliqueEye, kTableTarget, true);
  const pcl::IndicesPtr indices = roiIndices (*s.smoothed);
  const auto inside = insideMask (*s.smoothed, *indices);
  const auto masked = maskedCloud (*s.smoothed, *indices);

  auto edges_of = [&] (auto& estimation, bool use_indices) {
    estimation.setInputCloud (use_indices ? s.smoothed : masked);
    estimation.setInputNormals (s.normals);
    if (use_indices)
      estimation.setIndices (indices);
    pcl::PointCloud<pcl::Label> edges;
    estimation.compute (edges);
    return labelsOf (edges);
  };
  segmentation::ConcavityEdgeEstimation<pcl::PointXYZ, pcl::Normal> concavity, concavity_masked;
  segmentation::DepthDiscontinuityEdgeEstimation<pcl::PointXYZ, pcl::Normal> jumps, jumps_masked;
  const auto concave = edges_of (concavity, true);
  const auto depth_edges = edges_of (jumps, true);
  EXPECT_EQ (concave, edges_of (concavity_masked, false));
  EXPECT_EQ (depth_edges, edges_of (jumps_masked, false));
  std::size_t concave_inside = 0;
  for (std::size_t i = 0; i < concave.size (); ++i)
  {
    if (!inside[i])
    {
      ASSERT_EQ (concave[i], 0u) << i;
      ASSERT_EQ (depth_edges[i], 0u) << i;
    }
    concave_inside += concave[i];
  }
  EXPECT_GT (concave_inside, 100u);  // the seam between the boxes and their feet on the table

  // The plane is fitted to the indices' points; labels elsewhere stay as they were.
  cv::Mat labels = s.labels.clone ();
  segmentation::SupportPlaneRemoval<pcl::PointXYZ> removal;
  removal.setInputCloud (s.smoothed);
  removal.setInputNormals (s.normals);
  removal.setIndices (indices);
  ASSERT_TRUE (removal.apply (labels));
  std::size_t removed_inside = 0;
  for (std::size_t i = 0; i < inside.size (); ++i)
  {
    const std::int32_t before = reinterpret_cast<const std::int32_t*> (s.labels.data)[i];
    const std::int32_t after = reinterpret_cast<const std::int32_t*> (labels.data)[i];
    if (!inside[i])
    {
      ASSERT_EQ (after, before) << i;
    }
    else
      removed_inside += (before != 0 && after == 0) ? 1 : 0;
  }
  EXPECT_GT (removed_inside, 10000u);  // the table's part of the rectangle
}

TEST (PclConventions, AnIndexOutsideTheCloudIsAClearError)
{
  const auto s = segmentScene (kTwoBoxes, kObliqueEye, kTableTarget, false);
  pcl::IndicesPtr indices (new pcl::Indices{0, static_cast<pcl::index_t> (s.smoothed->size ())});
  Segmentation segmentation (asGiven ());
  segmentation.setInputCloud (s.smoothed);
  segmentation.setInputNormals (s.normals);
  segmentation.setIndices (indices);
  pcl::PointCloud<pcl::Label> labels;
  try
  {
    segmentation.segment (labels);
    FAIL () << "no error";
  }
  catch (const Error& e)
  {
    EXPECT_NE (std::string (e.what ()).find ("outside the input cloud"), std::string::npos) << e.what ();
    EXPECT_NE (std::string (e.what ()).find ("GeometricSegmentation"), std::string::npos) << e.what ();
  }
}

/** Components of pcl::OrganizedConnectedComponentSegmentation with \a comparator against
  * GeometricSegmentation with \a config (closings, small-segment removal and edge
  * assignment off): every segment is exactly one component and every unlabelled point
  * with depth a component of its own (an edge point).
  */
template <typename Comparator>
void
expectSameSegments (const SegmentedView& s, const segmentation::GeometricSegmentationConfig& config,
                    const typename Comparator::Ptr& comparator)
{
  Segmentation geometric (asGiven (config));
  geometric.setInputCloud (s.smoothed);
  geometric.setInputNormals (s.normals);
  pcl::PointCloud<pcl::Label> labels;
  geometric.segment (labels);

  comparator->setInputCloud (s.smoothed);
  comparator->setInputNormals (s.normals);
  pcl::OrganizedConnectedComponentSegmentation<pcl::PointXYZ, pcl::Label> components (comparator);
  components.setInputCloud (s.smoothed);
  pcl::PointCloud<pcl::Label> component_labels;
  std::vector<pcl::PointIndices> component_indices;
  components.segment (component_labels, component_indices);

  std::map<std::uint32_t, std::uint32_t> segment_to_component, component_to_segment;
  std::size_t edge_points = 0;
  for (std::size_t i = 0; i < labels.size (); ++i)
  {
    if (!std::isfinite ((*s.smoothed)[i].z))
      continue;
    const std::uint32_t segment = labels[i].label, component = component_labels[i].label;
    if (segment == 0)
    {
      ++edge_points;
      ASSERT_EQ (component_indices[component].indices.size (), 1u) << "edge point " << i << " joined a component";
      continue;
    }
    const auto a = segment_to_component.emplace (segment, component).first;
    const auto b = component_to_segment.emplace (component, segment).first;
    ASSERT_EQ (a->second, component) << "segment " << segment << " spans two components (point " << i << ")";
    ASSERT_EQ (b->second, segment) << "component " << component << " spans two segments (point " << i << ")";
  }
  EXPECT_EQ (segment_to_component.size (), static_cast<std::size_t> (geometric.getSegmentCount ()));
  EXPECT_GT (edge_points, 100u);
  EXPECT_GT (cv::countNonZero (comparator->getEdges ()), 0);
}

TEST (EdgeComparators, ComponentsAreGeometricSegmentationWithoutClosings)
{
  const auto s = segmentScene (kTwoBoxes, kObliqueEye, kTableTarget, true);
  segmentation::GeometricSegmentationConfig config;
  config.labeling.closing_iterations = 0;
  config.labeling.min_segment_size = 1;
  config.labeling.edge_assignment_radius = 0;

  expectSameSegments<segmentation::GeometricEdgeComparator<pcl::PointXYZ, pcl::Normal>> (
    s, config, std::make_shared<segmentation::GeometricEdgeComparator<pcl::PointXYZ, pcl::Normal>> (config));

  segmentation::GeometricSegmentationConfig concave_only = config;
  concave_only.use_discontinuity_edges = false;
  expectSameSegments<segmentation::ConcavityEdgeComparator<pcl::PointXYZ, pcl::Normal>> (
    s, concave_only, std::make_shared<segmentation::ConcavityEdgeComparator<pcl::PointXYZ, pcl::Normal>> (config.concavity));

  segmentation::GeometricSegmentationConfig jumps_only = config;
  jumps_only.use_concavity_edges = false;
  expectSameSegments<segmentation::DepthDiscontinuityEdgeComparator<pcl::PointXYZ, pcl::Normal>> (
    s, jumps_only,
    std::make_shared<segmentation::DepthDiscontinuityEdgeComparator<pcl::PointXYZ, pcl::Normal>> (config.discontinuity));
}

TEST (EdgeComparators, WithoutNormalsTheyRefuseClearly)
{
  const auto s = segmentScene (kTwoBoxes, kObliqueEye, kTableTarget, false);
  segmentation::GeometricEdgeComparator<pcl::PointXYZ, pcl::Normal> comparator;
  comparator.setInputCloud (s.smoothed);
  EXPECT_THROW (comparator.compare (0, 1), Error);
}

TEST (InstanceGuidedRegionMerge, MergesPclLabelCloudsLikeLabelImages)
{
  const auto s = segmentScene (kTwoBoxes, kObliqueEye, kTableTarget, true);
  simulation::DetectorErrorConfig errors;
  const std::vector<Instance> instances = simulatedInstances (kTwoBoxes, s, errors);
  ASSERT_FALSE (instances.empty ());
  segmentation::InstanceGuidedRegionMerge merge;
  cv::Mat fused;
  merge.merge (s.labels, instances, fused);

  pcl::PointCloud<pcl::PointXYZL> cloud;
  pcl::copyPointCloud (*s.smoothed, cloud);
  for (std::size_t i = 0; i < cloud.size (); ++i)
    cloud[i].label = static_cast<std::uint32_t> (reinterpret_cast<const std::int32_t*> (s.labels.data)[i]);
  pcl::PointCloud<pcl::PointXYZL> fused_cloud;
  merge.merge (cloud, instances, fused_cloud);
  ASSERT_EQ (fused_cloud.size (), cloud.size ());
  for (std::size_t i = 0; i < fused_cloud.size (); ++i)
  {
    ASSERT_EQ (fused_cloud[i].label, static_cast<std::uint32_t> (reinterpret_cast<const std::int32_t*> (fused.data)[i]));
    if (std::isfinite (cloud[i].z))
    {
      ASSERT_EQ (fused_cloud[i].z, cloud[i].z);
    }
  }
}
TEST (PclConventions, APointWithoutCoordinatesHasNoSegmentWhereTheHoleWasFilled)
{
  // With its defaults the class fills small holes of missing depth before segmenting
  // (SurfacePreprocessingConfig::max_hole_pixels), but a point without coordinates is in
  // no segment and in no list, as in segment-frame's output (toLabelledCloud).
  const auto s = segmentScene (kTwoBoxes, kObliqueEye, kTableTarget, true);
  const auto cloud = pcl::make_shared<pcl::PointCloud<pcl::PointXYZ>> (*s.cloud);
  std::vector<std::size_t> punched;
  for (int cy = 40; cy < static_cast<int> (cloud->height) - 40; cy += 37)
    for (int cx = 40; cx < static_cast<int> (cloud->width) - 40; cx += 53)
    {
      bool inside = true;  // 3x3 holes where the surface has depth all around
      for (int y = cy - 2; y <= cy + 2; ++y)
        for (int x = cx - 2; x <= cx + 2; ++x)
          inside = inside && std::isfinite ((*cloud) (x, y).z);
      if (!inside)
        continue;
      for (int y = cy - 1; y <= cy + 1; ++y)
        for (int x = cx - 1; x <= cx + 1; ++x)
        {
          (*cloud) (x, y).x = (*cloud) (x, y).y = (*cloud) (x, y).z = std::numeric_limits<float>::quiet_NaN ();
          punched.push_back (static_cast<std::size_t> (y) * cloud->width + x);
        }
    }
  ASSERT_GE (punched.size (), 9u * 20u);
  segmentation::GeometricSegmentation<pcl::PointXYZ, pcl::Normal> segmentation;
  segmentation.setInputCloud (cloud);
  pcl::PointCloud<pcl::PointXYZL> labels;
  std::vector<pcl::PointIndices> label_indices;
  segmentation.segment (labels, label_indices);
  std::set<pcl::index_t> listed;
  for (const pcl::PointIndices& indices : label_indices)
    listed.insert (indices.indices.begin (), indices.indices.end ());
  for (const std::size_t i : punched)
  {
    EXPECT_EQ (labels[i].label, 0u) << "point " << i;
    EXPECT_EQ (listed.count (static_cast<pcl::index_t> (i)), 0u) << "point " << i;
  }
  // The holes were filled for the segmentation: the surface around each is one segment.
  std::size_t whole = 0;
  for (std::size_t k = 0; k < punched.size (); k += 9)
  {
    const std::size_t centre = punched[k + 4], w = cloud->width;
    whole += labels[centre - 2].label != 0 && labels[centre - 2].label == labels[centre + 2].label &&
             labels[centre - 2].label == labels[centre - 2 * w].label && labels[centre - 2].label == labels[centre + 2 * w].label;
  }
  EXPECT_GE (whole * 10, punched.size () / 9 * 8);  // most holes lie inside one segment
}

}  // namespace test
}  // namespace cuefusion
