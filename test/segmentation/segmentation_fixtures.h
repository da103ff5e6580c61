// SPDX-License-Identifier: BSD-3-Clause
#pragma once
// Synthetic organized views with exact instance masks for the segmentation tests.

#include "test_utils.h"

#include <cuefusion/common/label_colors.h>
#include <cuefusion/common/instance.h>
#include <cuefusion/simulation/scene_renderer.h>
#include <cuefusion/simulation/simulated_detector.h>
#include <cuefusion/simulation/synthetic_scene.h>
#include <cuefusion/segmentation/geometric_segmentation.h>
#include <cuefusion/segmentation/surface_preprocessing.h>

#include <pcl/point_types.h>

#include <opencv2/imgcodecs.hpp>

#include <cstdlib>
#include <map>
#include <string>

namespace cuefusion
{
namespace test
{
using cuefusion::lookAt;

// Scene bodies shared by the segmentation tests (object ids follow file order: the
// table is 1), seen from kObliqueEye towards kTableTarget unless a test says otherwise.
const std::string kTable = "object table class=dining_table color=140,100,60 detectable=no\n"
                           "  box center=0,0,0.72 size=1.2,0.8,0.04\n";
/** Two boxes touching side by side; box_b stands 2 cm further back, so a concave seam shows. */
const std::string kTwoBoxes = kTable +
                              "object box_a class=box color=220,120,30\n"
                              "  box center=-0.07,0,0.84 size=0.14,0.10,0.20\n"
                              "object box_b class=box color=30,170,190\n"
                              "  box center=0.07,0.02,0.81 size=0.14,0.06,0.14\n";
const Eigen::Vector3d kTableTarget (0.0, 0.0, 0.8);
const Eigen::Vector3d kObliqueEye (0.45, -0.85, 1.3);

/** One rendered view and its geometric segmentation. */
struct SegmentedView
{
  simulation::RenderedView view;
  pcl::PointCloud<pcl::PointXYZ>::Ptr cloud;
  pcl::PointCloud<pcl::PointXYZ>::Ptr smoothed;
  pcl::PointCloud<pcl::Normal>::Ptr normals;
  cv::Mat labels;  ///< CV_32S L^G
};

/** Organized cloud of a rendered depth map (NaN where depth is 0). */
inline pcl::PointCloud<pcl::PointXYZ>::Ptr
cloudFromDepth (const cv::Mat& depth, const PinholeCamera& camera)
{
  pcl::PointCloud<pcl::PointXYZ>::Ptr cloud (new pcl::PointCloud<pcl::PointXYZ> (depth.cols, depth.rows));
  cloud->is_dense = false;
  for (int y = 0; y < depth.rows; ++y)
    for (int x = 0; x < depth.cols; ++x)
    {
      const float z = depth.at<float> (y, x);
      pcl::PointXYZ& p = (*cloud) (x, y);
      if (z > 0.f)
        p = pcl::PointXYZ (static_cast<float> ((x - camera.cx) / camera.fx) * z,
                           static_cast<float> ((y - camera.cy) / camera.fy) * z, z);
      else
        p.x = p.y = p.z = std::numeric_limits<float>::quiet_NaN ();
    }
  return cloud;
}

/** Renders \a scene_body (object lines) from \a eye towards \a target at 640×480 and
  * segments it with the default configuration (or \a config).
  */
inline SegmentedView
segmentScene (const std::string& scene_body, const Eigen::Vector3d& eye, const Eigen::Vector3d& target, bool noise,
              const segmentation::GeometricSegmentationConfig& config = segmentation::GeometricSegmentationConfig ())
{
  const simulation::SyntheticScene scene =
    simulation::SyntheticScene::parse ("scene test\ncamera 640 480 525 525 319.5 239.5\n" + scene_body, "test scene");
  simulation::DepthNoiseConfig noise_config;
  noise_config.enabled = noise;
  SegmentedView out;
  out.view = simulation::SceneRenderer (scene).render (scene.camera, lookAt (eye, target), noise_config, 7);
  out.cloud = cloudFromDepth (out.view.depth, scene.camera);
  out.smoothed.reset (new pcl::PointCloud<pcl::PointXYZ>);
  out.normals.reset (new pcl::PointCloud<pcl::Normal>);
  segmentation::SurfacePreprocessing<pcl::PointXYZ> preprocessing;
  preprocessing.setInputCloud (out.cloud);
  preprocessing.compute (*out.smoothed, *out.normals);
  segmentation::GeometricSegmentationConfig given = config;
  given.preprocess = false;  // preprocessed above, with the smoothed cloud and its normals at hand
  segmentation::GeometricSegmentation<pcl::PointXYZ, pcl::Normal> segmentation (given);
  segmentation.setInputCloud (out.smoothed);
  segmentation.setInputNormals (out.normals);
  pcl::PointCloud<pcl::Label> labels;
  segmentation.segment (labels);
  out.labels = segmentation.getLabelImage ().clone ();
  // For looking at a failure: CUEFUSION_TEST_DUMP=DIR writes labels | edges | truth PNGs.
  if (const char* dir = std::getenv ("CUEFUSION_TEST_DUMP"))
  {
    static int counter = 0;
    cv::Mat edges;
    cv::merge (std::vector<cv::Mat>{cv::Mat::zeros (out.labels.size (), CV_8U), segmentation.getDiscontinuityEdges () * 255,
                                    segmentation.getConcavityEdges () * 255},
               edges);
    cv::Mat truth;
    out.view.instance.convertTo (truth, CV_32S);
    cv::Mat row;
    cv::hconcat (std::vector<cv::Mat>{colorizeLabels (out.labels), edges, colorizeLabels (truth)}, row);
    cv::imwrite (std::string (dir) + "/view" + std::to_string (counter++) + ".png", row);
  }
  return out;
}

/** The simulated network's instances on a rendered view of \a scene_body (the same text
  * segmentScene rendered), with the detector errors of \a errors.
  */
inline std::vector<Instance>
simulatedInstances (const std::string& scene_body, const SegmentedView& s, const simulation::DetectorErrorConfig& errors)
{
  const simulation::SyntheticScene scene =
    simulation::SyntheticScene::parse ("scene test\ncamera 640 480 525 525 319.5 239.5\n" + scene_body, "test scene");
  return simulation::toInstances (simulation::SimulatedDetector (scene, errors, 3).detect (s.view.instance, 0));
}

/** How one ground-truth object of a view is segmented. */
struct ObjectScore
{
  int pixels = 0;          ///< visible pixels of the object
  double best_iou = 0.0;   ///< IoU with the segment that overlaps it most
  double coverage = 0.0;   ///< share of the object's pixels in that segment
  int best_label = 0;
  int segments = 0;        ///< segments holding ≥ 10 % of the object's pixels
};

inline ObjectScore
scoreObject (const SegmentedView& s, std::uint16_t id)
{
  std::map<int, int> overlap, segment_size;
  ObjectScore score;
  for (int y = 0; y < s.labels.rows; ++y)
    for (int x = 0; x < s.labels.cols; ++x)
    {
      const int label = s.labels.at<std::int32_t> (y, x);
      if (label > 0)
        ++segment_size[label];
      if (s.view.instance.at<std::uint16_t> (y, x) == id)
      {
        ++score.pixels;
        if (label > 0)
          ++overlap[label];
      }
    }
  for (const auto& [label, count] : overlap)
  {
    const double iou = static_cast<double> (count) / (score.pixels + segment_size[label] - count);
    if (iou > score.best_iou)
    {
      score.best_iou = iou;
      score.best_label = label;
      score.coverage = static_cast<double> (count) / score.pixels;
    }
    if (count >= 0.1 * score.pixels)
      ++score.segments;
  }
  return score;
}
}  // namespace test
}  // namespace cuefusion
