// SPDX-License-Identifier: BSD-3-Clause
// `cuefusion segment-frame` on generated organized clouds and depth images.
#include "labelled_pcd.h"
#include "segmentation_fixtures.h"

#include <cuefusion/io/camera_io.h>
#include <cuefusion/io/file_io.h>

#include <boost/filesystem.hpp>
#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>
#include <nlohmann/json.hpp>
#include <pcl/features/integral_image_normal.h>
#include <pcl/io/pcd_io.h>

#include <algorithm>
#include <map>

using namespace cuefusion;

namespace
{
const char* kScene = "object table class=table color=140,100,60 detectable=no\n"
                     "  box center=0,0,0.72 size=1.2,0.8,0.04\n"
                     "object box class=box color=200,40,40\n"
                     "  box center=-0.15,0.05,0.80 size=0.16,0.12,0.12 yaw=30\n"
                     "object ball class=ball color=40,60,210\n"
                     "  sphere center=0.12,-0.05,0.81 radius=0.07\n";

class SegmentFrame : public ::testing::Test
{
protected:
  void
  SetUp () override
  {
    view = test::segmentScene (kScene, Eigen::Vector3d (0.3, -0.8, 1.35), Eigen::Vector3d (0, 0, 0.8), true);
    // The OSD layout: organized x y z rgba.
    pcl::PointCloud<pcl::PointXYZRGBA> cloud (view.cloud->width, view.cloud->height);
    for (std::size_t i = 0; i < cloud.size (); ++i)
    {
      cloud[i].getVector3fMap () = (*view.cloud)[i].getVector3fMap ();
      cloud[i].r = 10;
      cloud[i].g = 20;
      cloud[i].b = 30;
      cloud[i].a = 255;
    }
    boost::filesystem::create_directories (dir / "in");
    pcd = dir / "in/view.pcd";
    ASSERT_EQ (pcl::io::savePCDFileBinaryCompressed (pcd, cloud), 0);
  }

  /** The label field of an organized output PCD as an image. */
  cv::Mat
  readLabels (const std::string& path, pcl::PointCloud<pcl::PointXYZRGBL>& out)
  {
    EXPECT_EQ (pcl::io::loadPCDFile (path, out), 0) << path;
    test::expectLabelledPCD (path, 1);  // opens in pcl_viewer with the label selectable as colour
    cv::Mat labels (static_cast<int> (out.height), static_cast<int> (out.width), CV_32S);
    for (int y = 0; y < labels.rows; ++y)
      for (int x = 0; x < labels.cols; ++x)
        labels.at<std::int32_t> (y, x) = static_cast<std::int32_t> (out (x, y).label);
    return labels;
  }

  test::TempDir dir;
  test::SegmentedView view;
  std::string pcd;
};
}  // namespace

TEST_F (SegmentFrame, OrganizedPCDInLabelledPCDOut)
{
  const auto r = test::runCuefusion ("segment-frame " + pcd + " --out " + (dir / "out.pcd") + " --png " +
                                       (dir / "labels.png") + " --verbose",
                                     dir);
  ASSERT_EQ (r.code, 0) << r.err;
  EXPECT_NE (r.out.find ("segments; ms: load"), std::string::npos) << r.out;
  pcl::PointCloud<pcl::PointXYZRGBL> out;
  view.labels = readLabels (dir / "out.pcd", out);
  ASSERT_EQ (out.width, 640u);
  ASSERT_EQ (out.height, 480u);
  EXPECT_EQ (out (320, 240).r, 10);
  for (const std::uint16_t id : {2, 3})
    EXPECT_GE (test::scoreObject (view, id).best_iou, 0.75) << "object " << id;
  for (int y = 0; y < view.labels.rows; ++y)
    for (int x = 0; x < view.labels.cols; ++x)
      if (!std::isfinite (out (x, y).z))
      {
        ASSERT_EQ (view.labels.at<std::int32_t> (y, x), 0);
      }
  const cv::Mat png = cv::imread (dir / "labels.png", cv::IMREAD_COLOR);
  EXPECT_EQ (png.cols, 640);
  EXPECT_EQ (png.rows, 480);
}

TEST_F (SegmentFrame, DropSupportPlaneLeavesOnlyObjects)
{
  const auto r = test::runCuefusion ("segment-frame " + pcd + " --out " + (dir / "out.pcd") + " --drop-support-plane", dir);
  ASSERT_EQ (r.code, 0) << r.err;
  pcl::PointCloud<pcl::PointXYZRGBL> out;
  view.labels = readLabels (dir / "out.pcd", out);
  EXPECT_LT (test::scoreObject (view, 1).best_iou, 0.05);  // the table
  for (const std::uint16_t id : {2, 3})
    EXPECT_GE (test::scoreObject (view, id).best_iou, 0.75) << "object " << id;
}

TEST_F (SegmentFrame, DepthPNGWithIntrinsicsAndFolders)
{
  // The same view as a 16-bit depth PNG (mm) in a folder next to the PCD.
  io::writeImageAtomic (dir / "in/depth.png", io::depthToRaw (view.view.depth, 1000.0));
  PinholeCamera camera;
  camera.width = 640;
  camera.height = 480;
  camera.fx = camera.fy = 525;
  camera.cx = 319.5;
  camera.cy = 239.5;
  io::writeIntrinsicsLine (dir / "intrinsics.txt", camera);
  const auto r = test::runCuefusion ("segment-frame " + (dir / "in") + " --out " + (dir / "out") + " --png " +
                                       (dir / "png") + " --intrinsics " + (dir / "intrinsics.txt") + " --timings " +
                                       (dir / "t.json"),
                                     dir);
  ASSERT_EQ (r.code, 0) << r.err;
  for (const char* name : {"out/depth.pcd", "out/view.pcd", "png/depth.png", "png/view.png", "t.json"})
    EXPECT_TRUE (boost::filesystem::exists (dir / name)) << name;
  pcl::PointCloud<pcl::PointXYZRGBL> from_png, from_pcd;
  const cv::Mat a = readLabels (dir / "out/depth.pcd", from_png);
  view.labels = a;
  for (const std::uint16_t id : {2, 3})
    EXPECT_GE (test::scoreObject (view, id).best_iou, 0.75) << "object " << id;

  // Output folders named relative to the working directory, not existing yet (until
  // 2026-11-26 folder mode failed with "map::at": the folder's key changed once created).
  const auto relative = test::runCuefusion ("segment-frame in --out rel-out --png rel-png --intrinsics intrinsics.txt", dir, true);
  ASSERT_EQ (relative.code, 0) << relative.err;
  for (const char* name : {"rel-out/depth.pcd", "rel-out/view.pcd", "rel-png/depth.png"})
    EXPECT_TRUE (boost::filesystem::exists (dir / name)) << name;
}

TEST_F (SegmentFrame, BadInputIsOneLine)
{
  // An unorganized PCD.
  pcl::PointCloud<pcl::PointXYZ> flat;
  flat.push_back (pcl::PointXYZ (0, 0, 1));
  flat.push_back (pcl::PointXYZ (0, 1, 1));
  ASSERT_EQ (pcl::io::savePCDFileASCII (dir / "flat.pcd", flat), 0);
  auto r = test::runCuefusion ("segment-frame " + (dir / "flat.pcd") + " --out " + (dir / "o.pcd"), dir);
  EXPECT_EQ (r.code, 1);
  EXPECT_NE (r.err.find ("flat.pcd"), std::string::npos) << r.err;
  EXPECT_NE (r.err.find ("not organized"), std::string::npos) << r.err;
  EXPECT_EQ (std::count (r.err.begin (), r.err.end (), '\n'), 1) << r.err;
  EXPECT_FALSE (boost::filesystem::exists (dir / "o.pcd"));

  // Corrupt and missing files.
  test::writeFile (dir / "junk.pcd", "this is not a PCD\n");
  r = test::runCuefusion ("segment-frame " + (dir / "junk.pcd") + " --out " + (dir / "o.pcd"), dir);
  EXPECT_EQ (r.code, 1);
  EXPECT_NE (r.err.find ("junk.pcd"), std::string::npos) << r.err;
  r = test::runCuefusion ("segment-frame " + (dir / "missing.pcd") + " --out " + (dir / "o.pcd"), dir);
  EXPECT_EQ (r.code, 1);
  EXPECT_NE (r.err.find ("missing.pcd"), std::string::npos) << r.err;

  // An all-NaN organized cloud.
  pcl::PointCloud<pcl::PointXYZ> nan_cloud (8, 8);
  for (auto& p : nan_cloud.points)
    p.x = p.y = p.z = std::numeric_limits<float>::quiet_NaN ();
  ASSERT_EQ (pcl::io::savePCDFileBinary (dir / "nan.pcd", nan_cloud), 0);
  r = test::runCuefusion ("segment-frame " + (dir / "nan.pcd") + " --out " + (dir / "o.pcd"), dir);
  EXPECT_EQ (r.code, 1);
  EXPECT_NE (r.err.find ("no finite point"), std::string::npos) << r.err;

  // Usage: depth PNG without intrinsics, absurd parameters.
  io::writeImageAtomic (dir / "depth.png", cv::Mat (48, 64, CV_16U, cv::Scalar (1000)));
  r = test::runCuefusion ("segment-frame " + (dir / "depth.png") + " --out " + (dir / "o.pcd"), dir);
  EXPECT_EQ (r.code, 2);
  EXPECT_NE (r.err.find ("--intrinsics"), std::string::npos) << r.err;
  for (const char* bad : {"--concavity-threshold 2", "--noise-factor -1", "--closings 99", "--normals sobel",
                          "--range-sigma 0", "--normal-step 0", "--concavity-noise-slope -1", "--min-overlap 1.5"})
  {
    r = test::runCuefusion ("segment-frame " + pcd + " --out " + (dir / "o.pcd") + " " + bad, dir);
    EXPECT_EQ (r.code, 2) << bad;
    EXPECT_NE (r.err.find (std::string (bad).substr (0, std::string (bad).find (' '))), std::string::npos) << r.err;
  }
  EXPECT_FALSE (boost::filesystem::exists (dir / "o.pcd"));
}

TEST_F (SegmentFrame, InstanceMasksFusedOrAlone)
{
  // Masks = the true instances of box (2) and ball (3), as an external tool would write.
  cv::Mat ids = cv::Mat::zeros (480, 640, CV_16U);
  ids.setTo (4, view.view.instance == 2);
  ids.setTo (9, view.view.instance == 3);
  io::writeImageAtomic (dir / "masks.png", ids);
  test::writeFile (dir / "masks.json", R"({"instances": [{"id": 4, "class_id": 73, "class_name": "book", "score": 0.8},
                                                          {"id": 9, "class_id": 32, "class_name": "sports ball", "score": 0.9}]})");
  for (const std::string mode : {"fused", "masks"})
  {
    const std::string out = dir / (mode + ".pcd");
    const auto r = test::runCuefusion ("segment-frame " + pcd + " --out " + out + " --masks " + (dir / "masks.png") +
                                         " --mode " + mode,
                                       dir);
    ASSERT_EQ (r.code, 0) << r.err;
    pcl::PointCloud<pcl::PointXYZRGBL> cloud;
    view.labels = readLabels (out, cloud);
    for (const std::uint16_t id : {2, 3})
      EXPECT_GE (test::scoreObject (view, id).best_iou, 0.75) << mode << " object " << id;
    // The sidecar JSON names the class of the segment each object landed in.
    const auto json = nlohmann::json::parse (test::readFile (dir / (mode + ".json")));
    std::map<int, std::string> classes;
    for (const auto& s : json.at ("segments"))
      if (s.contains ("class_name"))
        classes[s.at ("label").get<int> ()] = s.at ("class_name").get<std::string> ();
    EXPECT_EQ (classes[test::scoreObject (view, 2).best_label], "book") << mode;
    EXPECT_EQ (classes[test::scoreObject (view, 3).best_label], "sports ball") << mode;
    if (mode == "masks")  // the table is in no mask: no segment
      EXPECT_LT (test::scoreObject (view, 1).best_iou, 0.01);
    else  // fused: geometry keeps the table
      EXPECT_GE (test::scoreObject (view, 1).best_iou, 0.75);
  }
  // Usage errors: a mode needing masks without any, both sources, a folder/file mismatch.
  auto r = test::runCuefusion ("segment-frame " + pcd + " --out " + (dir / "o.pcd") + " --mode masks", dir);
  EXPECT_EQ (r.code, 2);
  EXPECT_NE (r.err.find ("--mode masks needs --masks or --model"), std::string::npos) << r.err;
  r = test::runCuefusion ("segment-frame " + pcd + " --out " + (dir / "o.pcd") + " --masks a.png --model b.onnx", dir);
  EXPECT_EQ (r.code, 2);
  r = test::runCuefusion ("segment-frame " + pcd + " --out " + (dir / "o.pcd") + " --masks " + dir.str (), dir);
  EXPECT_EQ (r.code, 1);
  EXPECT_NE (r.err.find ("single mask PNG"), std::string::npos) << r.err;
  r = test::runCuefusion ("segment-frame " + pcd + " --out " + (dir / "o.pcd") + " --model " + (dir / "none.onnx"), dir);
  EXPECT_EQ (r.code, 1);
  EXPECT_NE (r.err.find ("no such model file"), std::string::npos) << r.err;
  EXPECT_FALSE (boost::filesystem::exists (dir / "o.pcd"));
}

TEST_F (SegmentFrame, FolderMasksMatchedByStemMissingMeansGeometry)
{
  boost::filesystem::create_directories (dir / "masks");
  cv::Mat ids = cv::Mat::zeros (480, 640, CV_16U);
  ids.setTo (1, view.view.instance == 2);
  io::writeImageAtomic (dir / "masks/view.png", ids);
  boost::filesystem::copy_file (pcd, dir / "in/other.pcd");  // no masks for this one
  const auto r = test::runCuefusion ("segment-frame " + (dir / "in") + " --out " + (dir / "out") + " --masks " +
                                       (dir / "masks") + " --mode masks",
                                     dir);
  ASSERT_EQ (r.code, 0) << r.err;
  EXPECT_NE (r.err.find ("no masks for"), std::string::npos) << r.err;
  EXPECT_EQ (std::count (r.err.begin (), r.err.end (), '\n'), 1) << r.err;  // logged once
  pcl::PointCloud<pcl::PointXYZRGBL> cloud;
  view.labels = readLabels (dir / "out/view.pcd", cloud);
  EXPECT_GE (test::scoreObject (view, 2).best_iou, 0.75);
  EXPECT_LT (test::scoreObject (view, 3).best_iou, 0.01);  // masks mode: the ball has no mask
  view.labels = readLabels (dir / "out/other.pcd", cloud);  // geometry only
  EXPECT_GE (test::scoreObject (view, 3).best_iou, 0.75);
}

TEST_F (SegmentFrame, FolderModeWritesEveryOutputOrNone)
{
  // A first call fills out/ and png/; the user keeps a file of their own in out/.
  const std::string command = "segment-frame " + (dir / "in") + " --out " + (dir / "out") + " --png " + (dir / "png");
  ASSERT_EQ (test::runCuefusion (command, dir).code, 0);
  test::writeFile (dir / "out/notes.txt", "mine");
  const std::string first_pcd = test::readFile (dir / "out/view.pcd"), first_png = test::readFile (dir / "png/view.png");

  // A second call whose last input is damaged: one line naming it, and both folders as
  // the first call left them (no view.pcd of the second call beside the first's files).
  test::writeFile (dir / "in/zz_damaged.pcd", "# .PCD v0.7\nVERSION 0.7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nCOUNT 1 1 1\n"
                                              "WIDTH 2\nHEIGHT 2\nPOINTS 4\nDATA binary\n");
  const auto damaged = test::runCuefusion (command, dir);
  EXPECT_EQ (damaged.code, 1) << damaged.err;
  EXPECT_NE (damaged.err.find ("zz_damaged.pcd"), std::string::npos) << damaged.err;
  EXPECT_EQ (std::count (damaged.err.begin (), damaged.err.end (), '\n'), 1) << damaged.err;
  EXPECT_EQ (test::readFile (dir / "out/view.pcd"), first_pcd);
  EXPECT_EQ (test::readFile (dir / "png/view.png"), first_png);
  EXPECT_EQ (test::readFile (dir / "out/notes.txt"), "mine");
  for (const char* folder : {"out", "png"})
    for (boost::filesystem::directory_iterator it (dir / folder), end; it != end; ++it)
    {
      const std::string name = it->path ().filename ().string ();
      EXPECT_TRUE (name == "view.pcd" || name == "view.png" || name == "notes.txt") << folder << "/" << name << " left behind";
    }
  // Into folders that did not exist: none is created.
  const auto fresh = test::runCuefusion ("segment-frame " + (dir / "in") + " --out " + (dir / "new") + " --png " + (dir / "newpng"), dir);
  EXPECT_EQ (fresh.code, 1) << fresh.err;
  EXPECT_FALSE (boost::filesystem::exists (dir / "new"));
  EXPECT_FALSE (boost::filesystem::exists (dir / "newpng"));

  // Two inputs of one stem would write one output file twice: refused by name.
  boost::filesystem::remove (dir / "in/zz_damaged.pcd");
  boost::filesystem::copy_file (dir / "in/view.pcd", dir / "in/view.png");
  const auto twins = test::runCuefusion (command, dir);
  EXPECT_EQ (twins.code, 1) << twins.err;
  EXPECT_NE (twins.err.find ("both would write the same output files"), std::string::npos) << twins.err;
  EXPECT_EQ (test::readFile (dir / "out/view.pcd"), first_pcd);
}

TEST_F (SegmentFrame, TheLibraryOnItsOwnGivesTheCommandsSegments)
{
  // The README's route: GeometricSegmentation on the organized cloud as the sensor gave it
  // (Kinect noise), nothing else set up. It must give what `segment-frame` gives, label for
  // label up to numbering; before the class preprocessed its input, it segmented the raw
  // cloud with the caller's normals and the objects fell apart (checked below).
  const auto r = test::runCuefusion ("segment-frame " + pcd + " --out " + (dir / "out.pcd"), dir);
  ASSERT_EQ (r.code, 0) << r.err;
  pcl::PointCloud<pcl::PointXYZRGBL> command_out;
  const cv::Mat command = readLabels (dir / "out.pcd", command_out);

  const auto cloud = pcl::make_shared<pcl::PointCloud<pcl::PointXYZRGBA>> ();
  ASSERT_EQ (pcl::io::loadPCDFile (pcd, *cloud), 0);
  segmentation::GeometricSegmentation<pcl::PointXYZRGBA, pcl::Normal> library;
  library.setInputCloud (cloud);
  pcl::PointCloud<pcl::PointXYZRGBL> labelled;
  std::vector<pcl::PointIndices> label_indices;
  library.segment (labelled, label_indices);
  std::map<std::uint32_t, std::uint32_t> to_command, to_library;
  std::size_t differ = 0, labelled_points = 0;
  for (int y = 0; y < command.rows; ++y)
    for (int x = 0; x < command.cols; ++x)
    {
      const auto a = static_cast<std::uint32_t> (command.at<std::int32_t> (y, x)), b = labelled (x, y).label;
      labelled_points += a != 0;
      if ((a == 0) != (b == 0))
      {
        ++differ;
        continue;
      }
      if (a == 0)
        continue;
      differ += to_command.emplace (b, a).first->second != a || to_library.emplace (a, b).first->second != b;
    }
  ASSERT_GT (labelled_points, 100000u);
  EXPECT_EQ (differ, 0u) << "of " << labelled_points << " labelled points";
  EXPECT_EQ (to_command.size (), label_indices.size () - 1);  // every segment matched
  view.labels = command;
  for (const std::uint16_t id : {2, 3})
    EXPECT_GE (test::scoreObject (view, id).best_iou, 0.75) << "object " << id;

  // The old route: the raw cloud with PCL's integral-image normals, segmented as given.
  const auto normals = pcl::make_shared<pcl::PointCloud<pcl::Normal>> ();
  pcl::IntegralImageNormalEstimation<pcl::PointXYZRGBA, pcl::Normal> estimation;
  estimation.setNormalEstimationMethod (estimation.AVERAGE_3D_GRADIENT);
  estimation.setMaxDepthChangeFactor (0.02f);
  estimation.setNormalSmoothingSize (10.f);
  estimation.setInputCloud (cloud);
  estimation.compute (*normals);
  segmentation::GeometricSegmentationConfig as_given;
  as_given.preprocess = false;
  library.setConfig (as_given);
  library.setInputNormals (normals);
  library.segment (labelled);
  view.labels = library.getLabelImage ().clone ();
  double worst = 1.0;
  for (const std::uint16_t id : {2, 3})
    worst = std::min (worst, test::scoreObject (view, id).best_iou);
  EXPECT_LT (worst, 0.75) << "the raw route was not worse: the test no longer shows what the default is for";
}

TEST_F (SegmentFrame, ASettingsFileDoesWhatTheOptionsDo)
{
  // --print-config writes the settings the options give (the library's Config fields);
  // that file given back with --config segments as the options did.
  const std::string options = " --no-concavity --min-segment-size 500 --max-depth-jump 0.03 --drop-support-plane";
  auto r = test::runCuefusion ("segment-frame --print-config" + options, dir);
  ASSERT_EQ (r.code, 0) << r.err;
  const nlohmann::json settings = nlohmann::json::parse (r.out);
  const nlohmann::json& geometry = settings.at ("geometry");
  EXPECT_EQ (geometry.at ("use_concavity_edges"), false);
  EXPECT_EQ (geometry.at ("labeling").at ("min_segment_size"), 500);
  EXPECT_EQ (geometry["labeling"].at ("max_depth_jump").dump (), "0.03");  // one option sets both
  EXPECT_EQ (geometry.at ("preprocessing").at ("normals").at ("max_depth_jump").dump (), "0.03");
  test::writeFile (dir / "settings.json", settings.dump (2));
  for (const auto& [out, args] : {std::pair<std::string, std::string> ("options.pcd", options),
                                  {"file.pcd", " --drop-support-plane --config " + (dir / "settings.json")},
                                  {"defaults.pcd", " --drop-support-plane"}})
  {
    r = test::runCuefusion ("segment-frame " + pcd + " --out " + (dir / out) + args, dir);
    ASSERT_EQ (r.code, 0) << out << ": " << r.err;
  }
  EXPECT_EQ (test::readFile (dir / "file.pcd"), test::readFile (dir / "options.pcd"));
  EXPECT_NE (test::readFile (dir / "defaults.pcd"), test::readFile (dir / "options.pcd"));  // the settings matter here
}
