// SPDX-License-Identifier: BSD-3-Clause
// Normal estimation for the geometric segmentation, measured: angular error against the
// exact normals of noisy synthetic views of the bundled tabletop scene, and time, for
// SurfacePreprocessing's central differences (several steps) and PCL's
// IntegralImageNormalEstimation. Used by scripts/bench; prints one Markdown table.
// Usage: cuefusion_bench_normals SCENE_FILE [FRAMES]
#include <cuefusion/simulation/scene_renderer.h>
#include <cuefusion/simulation/synthetic_scene.h>
#include <cuefusion/simulation/synthetic_sequence.h>
#include <cuefusion/segmentation/surface_preprocessing.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <iostream>
#include <string>
#include <vector>

using namespace cuefusion;

int
main (int argc, char** argv)
{
  if (argc < 2)
  {
    std::cerr << "usage: cuefusion_bench_normals SCENE_FILE [FRAMES]\n";
    return 2;
  }
  const int frames = argc > 2 ? std::max (1, std::atoi (argv[2])) : 8;
  simulation::SyntheticSequenceConfig config;
  config.frames = static_cast<std::size_t> (frames);
  config.noise.enabled = true;
  const simulation::SyntheticScene scene = simulation::SyntheticScene::load (argv[1]);
  const simulation::SyntheticSequence sequence (scene, config);
  const simulation::SceneRenderer renderer (scene);

  struct Variant
  {
    std::string name;
    segmentation::SurfacePreprocessingConfig config;
    std::vector<double> errors, ms;
    std::size_t with_normal = 0, valid = 0;
  };
  std::vector<Variant> variants;
  for (const int step : {1, 2, 4, 6})
  {
    Variant v;
    v.name = "central differences ±" + std::to_string (step) + " px";
    v.config.normals.step = step;
    variants.push_back (v);
  }
  Variant integral;
  integral.name = "PCL IntegralImage (AVERAGE_3D_GRADIENT, 10 px)";
  integral.config.normal_method = segmentation::NormalMethod::IntegralImage;
  variants.push_back (integral);

  for (int f = 0; f < frames; ++f)
  {
    const simulation::RenderedView view =
      renderer.render (sequence.camera (), sequence.poseAt (static_cast<std::size_t> (f)), config.noise, simulation::mixSeed (1, f));
    const PinholeCamera& c = sequence.camera ();
    pcl::PointCloud<pcl::PointXYZ>::Ptr cloud (new pcl::PointCloud<pcl::PointXYZ> (view.depth.cols, view.depth.rows));
    for (int y = 0; y < view.depth.rows; ++y)
      for (int x = 0; x < view.depth.cols; ++x)
      {
        const float z = view.depth.at<float> (y, x);
        (*cloud) (x, y) = z > 0.f ? pcl::PointXYZ (static_cast<float> ((x - c.cx) / c.fx) * z,
                                                   static_cast<float> ((y - c.cy) / c.fy) * z, z)
                                  : pcl::PointXYZ (NAN, NAN, NAN);
      }
    for (Variant& v : variants)
    {
      segmentation::SurfacePreprocessing<pcl::PointXYZ> preprocessing (v.config);
      preprocessing.setInputCloud (cloud);
      pcl::PointCloud<pcl::PointXYZ> smoothed;
      pcl::PointCloud<pcl::Normal> normals;
      preprocessing.compute (smoothed, normals);
      v.ms.push_back (preprocessing.getNormalTime ());
      for (int y = 0; y < view.depth.rows; ++y)
        for (int x = 0; x < view.depth.cols; ++x)
        {
          if (!(view.depth.at<float> (y, x) > 0.f))
            continue;
          ++v.valid;
          const Eigen::Vector3f n = normals (x, y).getNormalVector3fMap ();
          if (!std::isfinite (n.x ()))
            continue;
          ++v.with_normal;
          const cv::Vec3f t = view.normals.at<cv::Vec3f> (y, x);
          const float cosine = std::min (1.f, std::abs (n.dot (Eigen::Vector3f (t[0], t[1], t[2]))));
          v.errors.push_back (std::acos (cosine) * 180.0 / M_PI);
        }
    }
  }
  auto quantile = [] (std::vector<double> values, double q) {
    std::sort (values.begin (), values.end ());
    return values.empty () ? NAN : values[static_cast<std::size_t> (q * (values.size () - 1))];
  };
  std::printf ("| normals (%d noisy %dx%d tabletop views) | median error ° | 90th pct ° | share < 7.7° (Φ threshold) | pixels with a normal | ms (median) |\n",
               frames, sequence.camera ().width, sequence.camera ().height);
  std::printf ("|---|---|---|---|---|---|\n");
  for (const Variant& v : variants)
  {
    const double below = static_cast<double> (std::count_if (v.errors.begin (), v.errors.end (), [] (double e) { return e < 7.7; })) /
                         std::max<std::size_t> (1, v.errors.size ());
    std::printf ("| %s | %.2f | %.2f | %.1f %% | %.1f %% | %.2f |\n", v.name.c_str (), quantile (v.errors, 0.5),
                 quantile (v.errors, 0.9), 100.0 * below, 100.0 * v.with_normal / std::max<std::size_t> (1, v.valid),
                 quantile (v.ms, 0.5));
  }
  return 0;
}
