// SPDX-License-Identifier: BSD-3-Clause
// `cuefusion eval`, `cuefusion render` and run's --render / --video / --view, end to end
// on a generated sequence.
#include "test_utils.h"

#include <cuefusion/common/label_colors.h>

#include <boost/filesystem.hpp>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/videoio.hpp>

#include <algorithm>
#include <cstdlib>
#include <set>

using namespace cuefusion;
namespace fs = boost::filesystem;

namespace
{
int
lineCount (const std::string& s)
{
  return static_cast<int> (std::count (s.begin (), s.end (), '\n'));
}

/** One 320×240 tabletop sequence shared by the tests of this file (rendering it is the
  * slow part), made once per build (test::sharedFixture). */
class EvalCli : public ::testing::Test
{
protected:
  static void
  SetUpTestSuite ()
  {
    shared_ = test::sharedFixture ("eval-cli-tabletop", [] (const std::string& folder) {
      test::TempDir logs;
      const auto r = test::runCuefusion ("synth --scene tabletop --frames 10 --size 320x240 --layout redwood --out " + folder + "/seq", logs);
      ASSERT_EQ (r.code, 0) << r.err;
    });
  }
  test::CommandResult
  run (const std::string& args)
  {
    return test::runCuefusion (args, dir);
  }
  static std::string
  seq ()
  {
    return shared_ + "/seq";
  }
  static nlohmann::json
  json (const std::string& path)
  {
    return nlohmann::json::parse (test::readFile (path));
  }
  /** Pixels of \a image (BGR) equal to some label's palette colour, per label. */
  static std::map<std::uint32_t, int>
  paletteHits (const cv::Mat& image, const std::set<std::uint32_t>& labels)
  {
    std::map<std::uint32_t, int> hits;
    for (int r = 0; r < image.rows; ++r)
      for (int c = 0; c < image.cols; ++c)
      {
        const cv::Vec3b bgr = image.at<cv::Vec3b> (r, c);
        for (const std::uint32_t label : labels)
        {
          const cv::Vec3b rgb = labelColor (label);
          if (std::abs (bgr[0] - rgb[2]) <= 2 && std::abs (bgr[1] - rgb[1]) <= 2 && std::abs (bgr[2] - rgb[0]) <= 2)
            ++hits[label];
        }
      }
    return hits;
  }
  static std::string shared_;
  test::TempDir dir;
};
std::string EvalCli::shared_;
}  // namespace

TEST_F (EvalCli, ReportsTrackingObjectIoUAndInstanceAP)
{
  auto r = run ("run " + seq () + " --use-gt-poses --mode masks --masks " + seq () + "/detections --save-every 1 --out " + (dir / "masks"));
  ASSERT_EQ (r.code, 0) << r.err;
  // (10 frames over the whole 80° orbit are 9° apart: too far for ICP, so both runs use
  // the sequence's poses; tracking accuracy itself is tested in test_reconstruction.)
  r = run ("run " + seq () + " --use-gt-poses --mode geometry --out " + (dir / "geometry"));
  ASSERT_EQ (r.code, 0) << r.err;
  r = run ("eval --run masks=" + (dir / "masks") + " --run " + (dir / "geometry") + " --gt " + seq () + " --out " + (dir / "report"));
  ASSERT_EQ (r.code, 0) << r.err;
  const nlohmann::json report = json (dir / "report/report.json");
  ASSERT_EQ (report.at ("runs").size (), 2u);
  const nlohmann::json& masks = report["runs"][0];
  const nlohmann::json& geometry = report["runs"][1];
  EXPECT_EQ (masks.at ("name"), "masks");
  EXPECT_EQ (geometry.at ("name"), "geometry");  // default name: the folder's
  EXPECT_EQ (report.at ("frames_with_masks").get<int> (), 10);
  // Tracking: the sequence's own poses give no error.
  EXPECT_LT (masks["tracking"]["ate"]["rmse"].get<double> (), 1e-6);
  EXPECT_LT (geometry["tracking"]["ate"]["rmse"].get<double> (), 1e-6);
  EXPECT_EQ (geometry["tracking"]["rpe_1_frame"]["pairs"].get<int> (), 9);
  EXPECT_TRUE (geometry["tracking"]["rpe_1_s"].is_null ());  // 10 frames at 30 Hz are shorter than 1 s
  // With a perfect simulated detector, masks-only maps are nearly the truth: every
  // object is found in every frame and in 3D.
  EXPECT_EQ (masks["object_iou"]["frames_scored"].get<int> (), 10);
  EXPECT_EQ (masks["object_iou"]["objects"].size (), 8u);  // the 8 detectable objects; stuff is not scored
  EXPECT_GT (masks["object_iou"]["mean"].get<double> (), 0.8);
  EXPECT_GT (masks["instance_ap"]["class_agnostic"]["ap50"].get<double> (), 0.8);
  EXPECT_EQ (masks["instance_ap"]["truth_instances"].get<int> (), 8);
  EXPECT_FALSE (masks["instance_ap"]["per_class"].empty ());
  // Geometry alone splits non-convex objects and has no classes.
  EXPECT_GT (masks["object_iou"]["mean"].get<double> (), geometry["object_iou"]["mean"].get<double> ());
  EXPECT_LT (geometry["instance_ap"]["class_mean"]["ap50"].get<double> (), 0.05);
  for (const char* csv : {"tracking.csv", "object_iou.csv", "object_iou_frames.csv", "instance_ap.csv"})
  {
    const std::string text = test::readFile (dir / ("report/" + std::string (csv)));
    EXPECT_GT (lineCount (text), 2) << csv;
  }
  // 10 frames × 8 objects × 2 runs + header.
  EXPECT_EQ (lineCount (test::readFile (dir / "report/object_iou_frames.csv")), 161);
  ASSERT_TRUE (report.contains ("plots"));
  if (report.contains ("plots_note"))
    ADD_FAILURE () << "plots were skipped: " << report["plots_note"];  // scripts/setup installs gnuplot
  EXPECT_EQ (report["plots"].size (), 8u + 2u);  // per object, mean IoU, trajectory
  for (const auto& png : report["plots"])
  {
    const cv::Mat image = cv::imread (png.get<std::string> ());
    EXPECT_FALSE (image.empty ()) << png;
    EXPECT_TRUE (fs::exists (fs::path (png.get<std::string> ()).replace_extension (".gp"))) << png;
  }

  // Per-frame labels (the run's labels/) instead of the final map.
  r = run ("eval --run " + (dir / "masks") + " --gt " + seq () + " --labels per-frame --no-plots --out " + (dir / "report2"));
  ASSERT_EQ (r.code, 0) << r.err;
  const nlohmann::json per_frame = json (dir / "report2/report.json");
  EXPECT_EQ (per_frame["runs"][0]["object_iou"]["frames_scored"].get<int> (), 10);
  EXPECT_GT (per_frame["runs"][0]["object_iou"]["mean"].get<double> (), 0.8);
  EXPECT_TRUE (per_frame["plots"].empty ());
}

TEST_F (EvalCli, EvalBadInput)
{
  auto r = run ("eval --gt " + seq () + " --out " + (dir / "r"));
  EXPECT_EQ (r.code, 2) << r.err;
  r = run ("eval --run " + (dir / "nope") + " --gt " + seq () + " --out " + (dir / "r"));
  EXPECT_EQ (r.code, 1);
  EXPECT_EQ (lineCount (r.err), 1) << r.err;
  EXPECT_NE (r.err.find ("nope"), std::string::npos) << r.err;
  fs::create_directories (dir / "empty_run");
  r = run ("eval --run " + (dir / "empty_run") + " --gt " + seq () + " --out " + (dir / "r"));
  EXPECT_EQ (r.code, 1);
  EXPECT_NE (r.err.find ("trajectory.txt"), std::string::npos) << r.err;
  r = run ("eval --run a=" + seq () + " --run a=" + seq () + " --gt " + seq () + " --out " + (dir / "r"));
  EXPECT_EQ (r.code, 2);
  r = run ("eval --run " + seq () + " --gt " + seq () + " --labels sometimes --out " + (dir / "r"));
  EXPECT_EQ (r.code, 2);
  EXPECT_NE (r.err.find ("--labels"), std::string::npos) << r.err;
  EXPECT_FALSE (fs::exists (dir / "r/report.json"));
}

TEST_F (EvalCli, RunRendersPanelsAndVideoAndRenderDrawsTheMesh)
{
  auto r = run ("run " + seq () + " --use-gt-poses --mode masks --masks " + seq () + "/detections --out " + (dir / "run") + " --render " +
                (dir / "panels") + " --video " + (dir / "run/video.avi"));
  ASSERT_EQ (r.code, 0) << r.err;
  int panels = 0;
  for (const fs::directory_entry& e : fs::directory_iterator (dir / "panels"))
  {
    const cv::Mat image = cv::imread (e.path ().string ());
    EXPECT_EQ (image.cols, 3 * 320) << e.path ();
    EXPECT_EQ (image.rows, 240) << e.path ();
    ++panels;
  }
  EXPECT_EQ (panels, 10);
  cv::VideoCapture video (dir / "run/video.avi");
  ASSERT_TRUE (video.isOpened ());
  int frames = 0;
  cv::Mat image;
  while (video.read (image))
  {
    EXPECT_EQ (image.cols, 3 * 320);
    ++frames;
  }
  EXPECT_EQ (frames, 10);
  for (const fs::directory_entry& e : fs::directory_iterator (dir / "run"))
    EXPECT_EQ (e.path ().filename ().string ().find (".tmp"), std::string::npos) << e.path ();

  // render: N views of the labelled mesh, coloured with the segments' palette colours.
  r = run ("render --run " + (dir / "run") + " --views 3 --size 640x480");
  ASSERT_EQ (r.code, 0) << r.err;
  std::set<std::uint32_t> labels;
  const nlohmann::json segments = json (dir / "run/segments.json");
  for (const auto& s : segments.at ("segments"))
    labels.insert (s.at ("id").get<std::uint32_t> ());
  for (int k = 0; k < 3; ++k)
  {
    const cv::Mat view = cv::imread (dir / ("run/renders/view_0" + std::to_string (k) + ".png"));
    ASSERT_FALSE (view.empty ());
    EXPECT_EQ (view.cols, 640);
    // Faces are shaded, so palette colours appear scaled by the light: count pixels whose
    // colour is a positive multiple of some segment's palette colour.
    std::set<std::uint32_t> seen;
    std::map<std::uint32_t, int> hits;
    for (int y = 0; y < view.rows; ++y)
      for (int x = 0; x < view.cols; ++x)
      {
        const cv::Vec3b p = view.at<cv::Vec3b> (y, x);
        for (const std::uint32_t label : labels)
        {
          const cv::Vec3b rgb = labelColor (label);
          const int m = std::max ({rgb[0], rgb[1], rgb[2]});
          const double shade = static_cast<double> (std::max ({p[0], p[1], p[2]})) / m;
          if (shade > 0.3 && shade <= 1.0 && std::abs (p[2] - shade * rgb[0]) <= 3 && std::abs (p[1] - shade * rgb[1]) <= 3 &&
              std::abs (p[0] - shade * rgb[2]) <= 3 && m - std::min ({rgb[0], rgb[1], rgb[2]}) > 40)
            ++hits[label];
        }
      }
    int coloured = 0;
    for (const auto& [label, n] : hits)
      coloured += n >= 50;
    EXPECT_GE (coloured, 4) << k;
  }
  EXPECT_EQ (run ("render --run " + (dir / "run") + " --views 0").code, 2);
  EXPECT_EQ (run ("render --run " + (dir / "run") + " --size 10").code, 2);
  r = run ("render --run " + (dir / "run") + " --frame floor");
  EXPECT_EQ (r.code, 2);
  EXPECT_NE (r.err.find ("--frame"), std::string::npos) << r.err;
  // From the run's own cameras: the scene as the camera saw it, its objects in view.
  r = run ("render --run " + (dir / "run") + " --from cameras --views 2 --size 320x240 --out " + (dir / "inside"));
  ASSERT_EQ (r.code, 0) << r.err;
  for (int k = 0; k < 2; ++k)
  {
    const cv::Mat view = cv::imread (dir / ("inside/view_0" + std::to_string (k) + ".png"));
    ASSERT_FALSE (view.empty ());
    cv::Mat grey;
    cv::cvtColor (view, grey, cv::COLOR_BGR2GRAY);
    EXPECT_GT (cv::countNonZero (grey < 250), view.total () / 2) << k;  // mostly mesh, not the white background
  }
  r = run ("render --run " + (dir / "run") + " --from above");
  EXPECT_EQ (r.code, 2);
  EXPECT_NE (r.err.find ("--from"), std::string::npos) << r.err;
  r = run ("render --run " + (dir / "nope"));
  EXPECT_EQ (r.code, 1);
  EXPECT_EQ (lineCount (r.err), 1) << r.err;
  // --video with an unknown container is refused before anything runs.
  r = run ("run " + seq () + " --out " + (dir / "run2") + " --video " + (dir / "v.gif"));
  EXPECT_EQ (r.code, 2);
  EXPECT_NE (r.err.find ("--video"), std::string::npos) << r.err;
}

TEST_F (EvalCli, LiveViewUnderXvfbShowsColouredSegments)
{
  if (std::system ("command -v xvfb-run >/dev/null 2>&1") != 0)
    GTEST_SKIP () << "xvfb-run is not installed (scripts/setup installs xvfb)";
  const std::string shot = dir / "shot.png";
  const std::string cmd = "xvfb-run -a -s '-screen 0 1600x1000x24' " + std::string (CUEFUSION_BINARY) + " run " + seq () +
                          " --use-gt-poses --mode masks --masks " + seq () + "/detections --out " + (dir / "run") +
                          " --view --view-screenshot " + shot + " >" + (dir / "view.out") + " 2>" + (dir / "view.err");
  const int status = std::system (cmd.c_str ());
  ASSERT_TRUE (WIFEXITED (status) && WEXITSTATUS (status) == 0) << test::readFile (dir / "view.err");
  EXPECT_TRUE (fs::exists (dir / "run/map.pcd"));  // the run's outputs are written as usual
  const cv::Mat image = cv::imread (shot);
  ASSERT_FALSE (image.empty ());
  std::set<std::uint32_t> labels;
  const nlohmann::json segments = json (dir / "run/segments.json");
  for (const auto& s : segments.at ("segments"))
    labels.insert (s.at ("id").get<std::uint32_t> ());
  ASSERT_GE (labels.size (), 8u);
  // The map's points are drawn unlit in their palette colours: several segments show.
  int segments_seen = 0;
  for (const auto& [label, n] : paletteHits (image, labels))
    segments_seen += n >= 30;
  EXPECT_GE (segments_seen, 4);

  // Without a display --view is a one-line error, not a crash.
  const std::string no_display = "env -u DISPLAY " + std::string (CUEFUSION_BINARY) + " run " + seq () + " --out " + (dir / "run4") +
                                 " --view >" + (dir / "nd.out") + " 2>" + (dir / "nd.err");
  const int nd = std::system (no_display.c_str ());
  EXPECT_TRUE (WIFEXITED (nd) && WEXITSTATUS (nd) == 1);
  const std::string err = test::readFile (dir / "nd.err");
  EXPECT_EQ (lineCount (err), 1) << err;
  EXPECT_NE (err.find ("DISPLAY"), std::string::npos) << err;
}

TEST_F (EvalCli, AsyncMasksRunTheSourceOnItsOwnThread)
{
  const auto r = run ("run " + seq () + " --use-gt-poses --masks " + seq () + "/detections --async-masks --out " + (dir / "run"));
  ASSERT_EQ (r.code, 0) << r.err;
  const nlohmann::json tracking = json (dir / "run/tracking.json");
  EXPECT_EQ (tracking["segmentation"]["mask_source"].get<std::string> ().rfind ("async:", 0), 0u) << tracking.dump ();
  EXPECT_EQ (tracking["frames"].get<int> (), 10);
}

TEST_F (EvalCli, DatasetTextNeverRunsAsCode)
{
  // Class names come from the dataset and run names from the command line; both reach
  // the gnuplot scripts of the plots. A newline there would end gnuplot's string and
  // command, and `system` on the next line runs a shell command.
  const std::string seq_dir = dir / "seq";
  auto r = run ("synth --scene tabletop --frames 3 --size 80x60 --out " + seq_dir);
  ASSERT_EQ (r.code, 0) << r.err;
  const std::string class_marker = dir / "class_ran", run_marker = dir / "run_name_ran";
  nlohmann::json scene = json (seq_dir + "/scene.json");
  for (nlohmann::json& instance : scene.at ("instances"))
    instance["class_name"] = "mug'\nsystem 'touch " + class_marker + "'\r\nprint '\\";
  test::writeFile (seq_dir + "/scene.json", scene.dump ());
  // (a run folder whose name is not UTF-8: its path goes into outputs.json and report.json)
  const std::string run_dir = dir / "run-\xff\xfe";
  r = run ("run " + seq_dir + " --use-gt-poses --mode masks --masks " + seq_dir + "/detections --out '" + run_dir + "'");
  ASSERT_EQ (r.code, 0) << r.err;
  EXPECT_NO_THROW (json (run_dir + "/outputs.json"));
  r = run ("eval --min-pixels 1 --run 'x\nsystem \"touch " + run_marker + "\"\n#=" + run_dir + "' --gt " + seq_dir + " --out " + (dir / "report"));
  ASSERT_EQ (r.code, 0) << r.err;
  EXPECT_FALSE (fs::exists (class_marker));
  EXPECT_FALSE (fs::exists (run_marker));
  // The texts did reach the scripts, inside their quotes.
  int scripts_with_class = 0;
  for (fs::directory_iterator it (dir / "report/plots"), end; it != end; ++it)
    if (it->path ().extension () == ".gp")
    {
      const std::string gp = test::readFile (it->path ().string ());
      scripts_with_class += gp.find ("system ''touch " + class_marker) != std::string::npos ? 1 : 0;
      EXPECT_EQ (gp.find ("\nsystem"), std::string::npos) << it->path ();
      EXPECT_EQ (gp.find ('\r'), std::string::npos) << it->path ();
    }
  EXPECT_GT (scripts_with_class, 0);
}

TEST_F (EvalCli, AVideoCutShortByAFullDiskIsAnError)
{
  // OpenCV's video writer says nothing when the disk fills: the run read the file back.
  const std::string full = dir / "full";
  fs::create_directories (full);
  if (std::system (("mount -t tmpfs -o size=48k tmpfs " + full + " 2>/dev/null").c_str ()) != 0)
    GTEST_SKIP () << "mounting a small tmpfs needs root (CI runs as root)";
  struct Unmount
  {
    std::string at;
    ~Unmount () { (void) std::system (("umount " + at).c_str ()); }
  } unmount{full};
  const auto r = run ("run " + seq () + " --use-gt-poses --mode geometry --frames 4 --out " + (dir / "run") + " --video " + full + "/v.avi");
  EXPECT_EQ (r.code, 1) << r.err;
  EXPECT_EQ (lineCount (r.err), 1) << r.err;
  EXPECT_NE (r.err.find ("v.avi"), std::string::npos) << r.err;
  EXPECT_NE (r.err.find ("cut short"), std::string::npos) << r.err;
  EXPECT_TRUE (fs::is_empty (full));  // neither the video nor its temporary is left

  // The outputs themselves: the error names the file where the user will look for it,
  // never the staging folder it was being written in, and says why in cuefusion's words
  // (PCL's own "Error during raw_fallocate ()!" says neither).
  for (const std::string& command : {"run " + seq () + " --use-gt-poses --mode geometry --frames 4 --out " + full + "/o",
                                     std::string ("synth --scene tabletop --frames 2 --size 64x48 --out ") + full + "/s"})
  {
    const auto w = run (command);
    EXPECT_EQ (w.code, 1) << command << "\n" << w.err;
    EXPECT_EQ (lineCount (w.err), 1) << w.err;
    EXPECT_NE (w.err.find (full + (command[0] == 'r' ? "/o/" : "/s/")), std::string::npos) << w.err;
    EXPECT_NE (w.err.find ("the disk is full"), std::string::npos) << w.err;
    EXPECT_EQ (w.err.find ("staging"), std::string::npos) << w.err;
    EXPECT_EQ (w.err.find (".tmp-"), std::string::npos) << w.err;
  }
  EXPECT_TRUE (fs::is_empty (full));  // nothing half-written left behind
}
