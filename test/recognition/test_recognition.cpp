// SPDX-License-Identifier: BSD-3-Clause
// Instance mask sources: a real ONNX file through OpenCV DNN (generated at test time in
// the exact YOLO-seg layouts, outputs known), and mask folders.
#include "test_utils.h"

#include <cuefusion/io/file_io.h>
#include <cuefusion/simulation/random_scene.h>
#include <cuefusion/io/sequence.h>
#include <cuefusion/io/sequence_writer.h>
#include <cuefusion/simulation/synthetic_sequence.h>
#include <cuefusion/recognition/mask_folder_segmenter.h>
#include <cuefusion/recognition/onnx_instance_segmenter.h>
#include <cuefusion/recognition/onnx_model_check.h>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <pcl/io/pcd_io.h>

#include <cstdlib>
#include <iostream>
#include <map>

using namespace cuefusion;
using namespace cuefusion::recognition;

namespace
{
/** Writes SPEC as JSON and runs test/recognition/SCRIPT on it; returns the model's path. */
std::string
generateModel (const std::string& script, const test::TempDir& dir, const std::string& name, const nlohmann::json& spec)
{
  const std::string spec_path = dir / (name + ".json"), model = dir / (name + ".onnx");
  test::writeFile (spec_path, spec.dump ());
  const std::string cmd =
    std::string ("/usr/bin/python3 ") + CUEFUSION_TEST_SOURCE_DIR + "/recognition/" + script + " " + spec_path + " " + model;
  EXPECT_EQ (std::system (cmd.c_str ()), 0) << cmd;
  return model;
}

/** A model in a YOLO-seg layout (make_yolo_seg_onnx.py). */
std::string
makeModel (const test::TempDir& dir, const std::string& name, const nlohmann::json& spec)
{
  return generateModel ("make_yolo_seg_onnx.py", dir, name, spec);
}

// 64×64 input, 3 classes, 4 mask coefficients, 16×16 prototypes (input / 4).
// Prototype regions (channel, y0, y1, x0, x1 in prototype pixels, inclusive):
//   0: rows 0–15, cols 0–15 (everything)      1: rows 10–14, all columns
// Detections (cx, cy, w, h, objectness, class, class score, coefficient channel):
//   A: box x 12–52, y 8–40, class 1, score 0.9·0.8 = 0.72, mask channel 0 → the box
//   B: box x 8–32, y 30–56, class 2, score 0.855, channel 1 → rows 40–55 of the box
//      (the region starts at prototype row 10 = input row 40; the box ends at 56)
//   C: A moved 2 px, class 1, score 0.3 → suppressed by A (same class, IoU 0.9)
//   D: A's box, class 0, score 0.5 → kept: NMS is per class
//   E: score 0.05 → below the threshold
nlohmann::json
spec (const std::string& layout)
{
  return {{"layout", layout},
          {"input", 64},
          {"classes", 3},
          {"coefficients", 4},
          {"proto_size", 16},
          {"regions", {{0, 0, 15, 0, 15}, {1, 10, 14, 0, 15}}},
          {"detections",
           {{32, 24, 40, 32, 0.9, 1, 0.8, 0},
            {20, 43, 24, 26, 0.95, 2, 0.9, 1},
            {34, 24, 40, 32, 0.5, 1, 0.6, 0},
            {32, 24, 40, 32, 1.0, 0, 0.5, 0},
            {5, 5, 4, 4, 0.1, 0, 0.5, 2}}}};
}

/** A model in the xyz layout (make_dense_onnx.py). */
std::string
makeDenseModel (const test::TempDir& dir, const std::string& name, const nlohmann::json& spec)
{
  return generateModel ("make_dense_onnx.py", dir, name, spec);
}

// 64×64 xyz input, output 32×32 (frame pixel = 2 × output pixel). Rectangles (y0, y1,
// x0, x1 in output pixels, inclusive; logit):
//   A: foreground rows 2–9, cols 2–13                       → one instance
//   E: foreground rows 2–9, cols 20–29 at logit 0.2 (p 0.55) → below score_threshold 0.6
//   B|C: foreground rows 14–25, cols 4–27 with a boundary band at cols 15–16 → two seeds
//        (cols 4–14 and 17–27); the band grows to B (col 15) and C (col 16)
//   D: foreground rows 28–29, cols 28–29: 4 output = 16 frame pixels < min_mask_pixels 20
nlohmann::json
denseSpec (int channels = 2)
{
  return {{"input", 64},
          {"channels", channels},
          {"foreground", {{2, 9, 2, 13, 10}, {2, 9, 20, 29, 0.2}, {14, 25, 4, 27, 10}, {28, 29, 28, 29, 10}}},
          {"boundary", {{14, 25, 15, 16, 10}}}};
}

/** A 64×64 frame 1 m from a wall (depth and camera; the xyz layout's input). */
RGBDFrame
wallFrame ()
{
  RGBDFrame frame;
  frame.camera = PinholeCamera (50, 50, 31.5, 31.5, 64, 64);
  frame.depth = cv::Mat (64, 64, CV_32F, cv::Scalar (1.f));
  frame.color = cv::Mat (64, 64, CV_8UC3, cv::Scalar (90, 90, 90));
  return frame;
}

class OnnxSegmenter : public ::testing::Test
{
protected:
  void
  SetUp () override
  {
    test::writeFile (dir / "abc.names", "alpha\nbeta\n  gamma  \n\n");
    config.classes_path = dir / "abc.names";
    config.input_size = 64;
  }

  std::vector<Instance>
  run (const std::string& model, const cv::Mat& color, OnnxLayout* layout = nullptr)
  {
    RGBDFrame frame;
    frame.color = color;
    return run (model, frame, layout);
  }

  std::vector<Instance>
  run (const std::string& model, const RGBDFrame& frame, OnnxLayout* layout = nullptr)
  {
    config.model_path = model;
    OnnxInstanceSegmenter segmenter (config);
    if (layout)
      *layout = segmenter.layout ();
    std::vector<Instance> instances;
    EXPECT_TRUE (segmenter.segment (frame, instances));
    return instances;
  }

  static cv::Mat
  boxMask (cv::Size size, const cv::Rect& box)
  {
    cv::Mat mask = cv::Mat::zeros (size, CV_8U);
    mask (box).setTo (1);
    return mask;
  }

  test::TempDir dir;
  OnnxInstanceSegmenterConfig config;
};
}  // namespace

TEST_F (OnnxSegmenter, DecodesBothYoloLayoutsExactly)
{
  for (const std::string layout : {"v5", "v8"})
  {
    OnnxLayout found;
    const auto instances = run (makeModel (dir, layout, spec (layout)), cv::Mat (64, 64, CV_8UC3, cv::Scalar (9, 9, 9)), &found);
    EXPECT_EQ (found, layout == "v5" ? OnnxLayout::V5 : OnnxLayout::V8);
    ASSERT_EQ (instances.size (), 3u) << layout;
    // Highest score first: B (0.855), A (0.72, or 0.8 in v8 which has no objectness), D.
    const float a_score = layout == "v5" ? 0.72f : 0.8f, b_score = layout == "v5" ? 0.855f : 0.9f;
    const Instance& b = instances[0];
    const Instance& a = instances[1];
    const Instance& d = instances[2];
    EXPECT_EQ (b.class_id, 2);
    EXPECT_EQ (b.class_name, "gamma");
    EXPECT_NEAR (b.score, b_score, 1e-6f);
    EXPECT_EQ (b.box, cv::Rect (8, 30, 24, 26));
    EXPECT_EQ (cv::countNonZero (b.mask != boxMask (cv::Size (64, 64), cv::Rect (8, 40, 24, 16))), 0) << layout;
    EXPECT_EQ (a.class_id, 1);
    EXPECT_EQ (a.class_name, "beta");
    EXPECT_NEAR (a.score, a_score, 1e-6f);
    EXPECT_EQ (a.box, cv::Rect (12, 8, 40, 32));
    EXPECT_EQ (cv::countNonZero (a.mask != boxMask (cv::Size (64, 64), a.box)), 0) << layout;
    EXPECT_EQ (d.class_id, 0);
    EXPECT_EQ (d.box, a.box);
  }
}

TEST_F (OnnxSegmenter, DecodesTheXyzLayoutExactly)
{
  config.dense_width = 64;
  config.min_mask_pixels = 20;
  config.score_threshold = 0.6f;
  OnnxLayout found;
  const auto instances = run (makeDenseModel (dir, "dense", denseSpec ()), wallFrame (), &found);
  EXPECT_EQ (found, OnnxLayout::Xyz);
  ASSERT_EQ (instances.size (), 3u);
  const cv::Size frame (64, 64);
  // Equal scores keep scan order: A, B, C. Frame rectangles are output × 2.
  const cv::Rect a (4, 4, 24, 16), b (8, 28, 24, 24), c (32, 28, 24, 24);
  for (const auto& [instance, box] : {std::make_pair (&instances[0], a), std::make_pair (&instances[1], b),
                                      std::make_pair (&instances[2], c)})
  {
    EXPECT_EQ (instance->box, box);
    EXPECT_EQ (cv::countNonZero (instance->mask != boxMask (frame, box)), 0) << box;
    EXPECT_EQ (instance->class_id, 0);
    EXPECT_EQ (instance->class_name, "object");
    EXPECT_NEAR (instance->score, 1.f / (1.f + std::exp (-10.f)), 1e-6f);
  }

  // Without the score threshold E comes back (score 0.55, last); a lower size floor keeps D.
  config.score_threshold = 0.5f;
  config.min_mask_pixels = 16;
  const auto more = run (dir / "dense.onnx", wallFrame ());
  ASSERT_EQ (more.size (), 5u);
  EXPECT_EQ (more[4].box, cv::Rect (40, 4, 20, 16));
  EXPECT_NEAR (more[4].score, 1.f / (1.f + std::exp (-0.2f)), 1e-6f);
  EXPECT_EQ (more[3].box, cv::Rect (56, 56, 4, 4));
}

TEST_F (OnnxSegmenter, XyzScoresAreRankedByStability)
{
  // B|C as above, but the band between them is only p = 0.35 a boundary: cut at the default
  // threshold 0.3 and at 0.2, joined at 0.4. Each half (rows 14–25 × 12 columns) is then
  // half of the joined mask: stability 0.5, score p(10) · 0.5. A's mask is the same at
  // every threshold: stability 1, ranked first.
  nlohmann::json spec = denseSpec ();
  spec["boundary"] = {{14, 25, 15, 16, std::log (0.35 / 0.65)}};
  config.dense_width = 64;
  config.min_mask_pixels = 20;
  config.score_threshold = 0.6f;
  const float p10 = 1.f / (1.f + std::exp (-10.f));
  const auto instances = run (makeDenseModel (dir, "weak_band", spec), wallFrame ());
  ASSERT_EQ (instances.size (), 3u);
  EXPECT_EQ (instances[0].box, cv::Rect (4, 4, 24, 16));
  EXPECT_NEAR (instances[0].score, p10, 1e-6f);
  EXPECT_EQ (instances[1].box, cv::Rect (8, 28, 24, 24));
  EXPECT_EQ (instances[2].box, cv::Rect (32, 28, 24, 24));
  EXPECT_NEAR (instances[1].score, 0.5f * p10, 1e-6f);
  EXPECT_NEAR (instances[2].score, 0.5f * p10, 1e-6f);

  // Without the stability term every score is the mean foreground again (scan order).
  config.stability_delta = 0.f;
  const auto plain = run (dir / "weak_band.onnx", wallFrame ());
  ASSERT_EQ (plain.size (), 3u);
  for (const Instance& instance : plain)
    EXPECT_NEAR (instance.score, p10, 1e-6f);

  // The score threshold applies to the mean foreground, not to the product: B and C stay.
  config.stability_delta = 0.1f;
  config.score_threshold = 0.9f;
  EXPECT_EQ (run (dir / "weak_band.onnx", wallFrame ()).size (), 3u);

  config.stability_delta = 0.7f;
  EXPECT_THROW (OnnxInstanceSegmenter{config}, ParameterError);
}

TEST (OnnxInstanceSegmenter, MasksWiderThanAnyTrainedObjectAreDropped)
{
  // 2 m away at f = 500 px a pixel is 4 mm: the default limit 0.56 m is 140 px. A mask's
  // width is the span of the middle 90 % of its columns over 0.9 (a filled rectangle's).
  RGBDFrame frame;
  frame.camera = PinholeCamera (500, 500, 319.5, 239.5, 640, 480);
  frame.depth = cv::Mat (480, 640, CV_32F, cv::Scalar (2.f));
  const auto mask = [&] (std::initializer_list<cv::Rect> rects, const std::string& name) {
    Instance instance;
    instance.mask = cv::Mat::zeros (480, 640, CV_8U);
    for (const cv::Rect& r : rects)
      instance.mask (r).setTo (255);
    instance.box = cv::boundingRect (instance.mask);
    instance.class_name = name;
    return instance;
  };
  std::vector<Instance> instances{
      mask ({cv::Rect (10, 10, 130, 40)}, "narrow"),                                // 0.52 m
      mask ({cv::Rect (10, 60, 150, 40)}, "wide"),                                  // 0.60 m
      mask ({cv::Rect (200, 10, 20, 150)}, "tall"),                                 // 0.60 m high
      mask ({cv::Rect (300, 10, 60, 40), cv::Rect (360, 30, 100, 1)}, "thread"),    // core 0.24 m, a 1 px thread to 0.64 m
      mask ({cv::Rect (300, 200, 100, 40)}, "rim far behind"),                     // its rim is the wall 4 m behind
      mask ({cv::Rect (10, 300, 400, 40)}, "no depth")};
  frame.depth (cv::Rect (300, 200, 100, 3)).setTo (6.f);
  frame.depth (cv::Rect (10, 300, 400, 40)).setTo (0.f);
  std::vector<Instance> kept = instances;
  OnnxInstanceSegmenter::dropWiderThan (frame, OnnxInstanceSegmenterConfig ().max_object_extent, kept);
  std::vector<std::string> names;
  for (const Instance& instance : kept)
    names.push_back (instance.class_name);
  EXPECT_EQ (names, (std::vector<std::string>{"narrow", "thread", "rim far behind", "no depth"}));

  // The limit scales with depth: at 1 m the wide mask is 0.30 m across.
  frame.depth /= 2.f;
  kept = instances;
  OnnxInstanceSegmenter::dropWiderThan (frame, 0.56f, kept);
  EXPECT_EQ (kept.size (), instances.size ());
  // 0 keeps every mask.
  frame.depth *= 2.f;
  kept = instances;
  OnnxInstanceSegmenter::dropWiderThan (frame, 0.f, kept);
  EXPECT_EQ (kept.size (), instances.size ());
  OnnxInstanceSegmenterConfig config;
  config.max_object_extent = -1.f;
  EXPECT_THROW (config.validate (), ParameterError);
}

TEST_F (OnnxSegmenter, XyzInputIsTheBackProjectedDepth)
{
  // 128×96 frame at dense_width 64: every second pixel, padded to 64×48 → 64×48 (a multiple of 16).
  RGBDFrame frame;
  frame.camera = PinholeCamera (100, 100, 63.5, 47.5, 128, 96);
  frame.depth = cv::Mat (96, 128, CV_32F, cv::Scalar (2.f));
  frame.depth.at<float> (10, 20) = 0.f;  // missing → xyz 0
  cv::Size content;
  const cv::Mat blob = OnnxInstanceSegmenter::xyzInput (frame, 64, content);
  EXPECT_EQ (content, cv::Size (64, 48));
  ASSERT_EQ (blob.dims, 4);
  EXPECT_EQ (blob.size[1], 3);
  EXPECT_EQ (blob.size[2], 48);
  EXPECT_EQ (blob.size[3], 64);
  auto at = [&] (int c, int y, int x) { return blob.ptr<float> (0, c)[y * 64 + x]; };
  EXPECT_FLOAT_EQ (at (0, 3, 7), (14 - 63.5f) / 100.f * 2.f);
  EXPECT_FLOAT_EQ (at (1, 3, 7), (6 - 47.5f) / 100.f * 2.f);
  EXPECT_FLOAT_EQ (at (2, 3, 7), 2.f);
  EXPECT_EQ (at (2, 5, 10), 0.f);
  frame.depth = cv::Mat ();
  test::expectError ([&] { OnnxInstanceSegmenter::xyzInput (frame, 64, content); }, "OnnxInstanceSegmenter", "depth");
}

TEST_F (OnnxSegmenter, XyzRgbLayoutSeesTheColourAsTrained)
{
  // Six input channels: the foreground logit is 40 × channel 3, which must be the red
  // channel scaled as train.py does (R / 255 − 0.5): red 128 on the left half gives logit
  // +0.078 (p 0.52, foreground), red 127 with blue 255 on the right −0.078 (background;
  // were blue read as red, the right half would be the object).
  nlohmann::json spec = {{"input", 64},
                         {"input_channels", 6},
                         {"foreground", {{0, 31, 0, 31, 0.0}}},
                         {"weights", {{0, 3, 40.0}}}};
  config.dense_width = 64;
  config.min_mask_pixels = 20;
  config.max_object_extent = 0.f;  // the wall frame's toy camera makes the half frame 1.3 m tall
  RGBDFrame frame = wallFrame ();
  frame.color (cv::Rect (0, 0, 32, 64)).setTo (cv::Scalar (0, 0, 128));
  frame.color (cv::Rect (32, 0, 32, 64)).setTo (cv::Scalar (255, 0, 127));
  OnnxLayout found;
  const auto instances = run (makeDenseModel (dir, "rgb", spec), frame, &found);
  EXPECT_EQ (found, OnnxLayout::XyzRgb);
  ASSERT_EQ (instances.size (), 1u);
  EXPECT_EQ (instances[0].box, cv::Rect (0, 0, 32, 64));
  EXPECT_EQ (cv::countNonZero (instances[0].mask != boxMask (cv::Size (64, 64), cv::Rect (0, 0, 32, 64))), 0);
  EXPECT_NEAR (instances[0].score, 1.f / (1.f + std::exp (-40.f * (128.f / 255.f - 0.5f))), 1e-5f);

  // The input: xyzInput's three channels, then RGB.
  cv::Size content, xyz_content;
  const cv::Mat blob = OnnxInstanceSegmenter::denseInput (frame, 64, OnnxLayout::XyzRgb, content);
  const cv::Mat xyz = OnnxInstanceSegmenter::xyzInput (frame, 64, xyz_content);
  EXPECT_EQ (content, xyz_content);
  ASSERT_EQ (blob.size[1], 6);
  const std::size_t plane = 64 * 64;
  EXPECT_TRUE (std::equal (xyz.ptr<float> (), xyz.ptr<float> () + 3 * plane, blob.ptr<float> ()));
  EXPECT_NEAR (blob.ptr<float> (0, 3)[5 * 64 + 40], 127.f / 255.f - 0.5f, 1e-6f);  // R
  EXPECT_NEAR (blob.ptr<float> (0, 4)[5 * 64 + 40], -0.5f, 1e-6f);                 // G
  EXPECT_NEAR (blob.ptr<float> (0, 5)[5 * 64 + 40], 0.5f, 1e-6f);                  // B

  // The layout is named, and needs the colour image.
  config.model_path = dir / "rgb.onnx";
  OnnxInstanceSegmenter segmenter (config);
  EXPECT_NE (segmenter.name ().find ("xyz and colour layout"), std::string::npos) << segmenter.name ();
  frame.color = cv::Mat ();
  std::vector<Instance> none;
  test::expectError ([&] { segmenter.segment (frame, none); }, "OnnxInstanceSegmenter", "colour image");

  // Six input channels and three outputs: no layout, and the message says which it expects.
  spec["channels"] = 3;
  config.model_path = makeDenseModel (dir, "rgb3", spec);
  test::expectError ([&] { OnnxInstanceSegmenter s (config); }, "rgb3.onnx", "6 input channels");
}

TEST_F (OnnxSegmenter, LetterboxMapsBackToTheFrame)
{
  // A 128×64 frame is scaled by 0.5 and padded 16 rows top and bottom in the 64×64 input:
  // input (x, y) is frame (2x, 2(y − 16)).
  Letterbox box;
  const cv::Mat input = OnnxInstanceSegmenter::letterbox (cv::Mat (64, 128, CV_8UC3, cv::Scalar (0, 0, 200)), 64, box);
  EXPECT_FLOAT_EQ (box.scale, 0.5f);
  EXPECT_EQ (box.pad_x, 0);
  EXPECT_EQ (box.pad_y, 16);
  EXPECT_EQ (input.at<cv::Vec3b> (5, 5), cv::Vec3b (114, 114, 114));
  EXPECT_EQ (input.at<cv::Vec3b> (30, 30), cv::Vec3b (0, 0, 200));

  nlohmann::json s = spec ("v5");
  s["detections"] = {{32, 32, 40, 16, 1.0, 1, 0.9, 0}};  // input x 12–52, y 24–40
  const auto instances = run (makeModel (dir, "letterbox", s), cv::Mat (64, 128, CV_8UC3, cv::Scalar (9, 9, 9)));
  ASSERT_EQ (instances.size (), 1u);
  EXPECT_EQ (instances[0].box, cv::Rect (24, 16, 80, 32));
  EXPECT_EQ (instances[0].mask.size (), cv::Size (128, 64));
  EXPECT_EQ (cv::countNonZero (instances[0].mask != boxMask (cv::Size (128, 64), cv::Rect (24, 16, 80, 32))), 0);
}

TEST_F (OnnxSegmenter, BadModelsAreClearErrors)
{
  config.model_path = dir / "missing.onnx";
  test::expectError ([&] { OnnxInstanceSegmenter s (config); }, "missing.onnx", "no such model file");

  test::writeFile (dir / "junk.onnx", "not a protobuf at all");
  config.model_path = dir / "junk.onnx";
  test::expectError ([&] { OnnxInstanceSegmenter s (config); }, "junk.onnx", "not a sound ONNX model");

  // Detections flattened to [1, N·D]: no YOLO-seg layout; the message names the shapes.
  config.model_path = makeModel (dir, "flat", spec ("flat"));
  test::expectError ([&] { OnnxInstanceSegmenter s (config); }, "flat.onnx", "[1, 60]");
  test::expectError ([&] { OnnxInstanceSegmenter s (config); }, "flat.onnx", "do not match");

  // The right layout with the wrong class list (80 COCO names for a 3-class model).
  config.model_path = makeModel (dir, "v5", spec ("v5"));
  config.classes_path = "";
  test::expectError ([&] { OnnxInstanceSegmenter s (config); }, "v5.onnx", "C = 80");

  // An xyz-like model with three output channels is no layout either.
  config.model_path = makeDenseModel (dir, "dense3", denseSpec (3));
  test::expectError ([&] { OnnxInstanceSegmenter s (config); }, "dense3.onnx", "[1, 3, 32, 32]");

  // The xyz layout needs depth.
  config.model_path = makeDenseModel (dir, "dense", denseSpec ());
  {
    OnnxInstanceSegmenter dense (config);
    RGBDFrame colour_only;
    colour_only.color = cv::Mat (64, 64, CV_8UC3, cv::Scalar (1, 2, 3));
    std::vector<Instance> instances;
    test::expectError ([&] { dense.segment (colour_only, instances); }, "OnnxInstanceSegmenter", "needs the frame's depth");
  }

  config.model_path = makeModel (dir, "v5", spec ("v5"));
  config.classes_path = dir / "none.names";
  test::expectError ([&] { OnnxInstanceSegmenter s (config); }, "none.names", "no such file");
  config.input_size = 100;
  EXPECT_THROW (OnnxInstanceSegmenter s (config), ParameterError);
}

namespace
{
/** Protobuf wire format, enough to write ONNX models with hand-made lies. */
std::string
varint (std::uint64_t v)
{
  std::string out;
  do
  {
    out += static_cast<char> ((v & 0x7fu) | (v > 0x7fu ? 0x80u : 0u));
    v >>= 7;
  } while (v);
  return out;
}
std::string
number (std::uint32_t field, std::uint64_t v)
{
  return varint (field << 3) + varint (v);
}
std::string
bytes (std::uint32_t field, const std::string& b)
{
  return varint ((field << 3) | 2u) + varint (b.size ()) + b;
}
/** A float TensorProto named w: its dims, then \a extra fields (data, location). */
std::string
tensor (const std::vector<std::uint64_t>& dims, const std::string& extra)
{
  std::string t;
  for (const std::uint64_t d : dims)
    t += number (1, d);
  return t + number (2, 1) + bytes (8, "w") + extra;
}
/** A model whose graph holds \a graph_fields. */
std::string
model (const std::string& graph_fields)
{
  return number (1, 8) + bytes (7, graph_fields);
}
}  // namespace

TEST (OnnxModelCheck, MalformedModelsAreRefusedBeforeOpenCVReadsThem)
{
  test::TempDir dir;
  // A sound initializer: 2 x 3 floats as raw data, as packed floats; a scalar.
  EXPECT_NO_THROW (checkOnnxModelBytes (model (bytes (5, tensor ({2, 3}, bytes (9, std::string (24, '\0'))))), "m"));
  EXPECT_NO_THROW (checkOnnxModelBytes (model (bytes (5, tensor ({2, 3}, bytes (4, std::string (24, '\0'))))), "m"));
  EXPECT_NO_THROW (checkOnnxModelBytes (model (bytes (5, tensor ({}, bytes (9, std::string (4, '\0'))))), "m"));

  // The two files that crashed OpenCV's importer inside `run` and `segment-frame`: huge
  // dims and no data, and data in an external file. Refused by the segmenter by name.
  OnnxInstanceSegmenterConfig config;
  test::writeFile (dir / "huge.onnx", model (bytes (5, tensor ({std::uint64_t{1} << 20, std::uint64_t{1} << 20}, ""))));
  config.model_path = dir / "huge.onnx";
  test::expectError ([&] { OnnxInstanceSegmenter s (config); }, "huge.onnx", "more than 2^31 values");
  test::writeFile (dir / "external.onnx", model (bytes (5, tensor ({4}, bytes (13, bytes (1, "location") + bytes (2, "w.bin")) + number (14, 1)))));
  config.model_path = dir / "external.onnx";
  test::expectError ([&] { OnnxInstanceSegmenter s (config); }, "external.onnx", "external data");

  const auto refused = [] (const std::string& file, const std::string& why) {
    test::expectError ([&] { checkOnnxModelBytes (file, "m.onnx"); }, "m.onnx", why);
  };
  refused (model (bytes (5, tensor ({4}, bytes (9, std::string (8, '\0'))))), "promise 4 values and which holds 2");
  refused (model (bytes (5, tensor ({4}, bytes (9, std::string (7, '\0'))))), "partial value");
  refused (model (bytes (5, tensor ({1000}, ""))), "holds 0");
  refused (model (bytes (5, tensor ({4}, number (14, 1) + bytes (9, std::string (16, '\0'))))), "external data");
  refused (model (bytes (5, tensor ({~std::uint64_t{0}}, ""))), "negative dimension");
  refused (model (bytes (5, tensor ({2}, number (2, 99) + bytes (9, "12345678")))), "unknown data type");
  refused (model (bytes (15, bytes (1, tensor ({3}, "")))), "holds 0");  // a sparse initializer's values
  refused (model (bytes (1, bytes (5, bytes (5, tensor ({9}, ""))))), "holds 0");  // a Constant node's tensor
  std::string nested = bytes (5, tensor ({}, ""));
  for (int i = 0; i < 20; ++i)
    nested = bytes (1, bytes (5, bytes (6, nested)));  // node → attribute → graph
  refused (model (nested), "nested more than 16");
  // A node reading a name nothing defines (OpenCV's importer crashed on it: found by
  // fuzzing), and a graph output defined nowhere.
  const std::string conv = bytes (1, bytes (1, "x") + bytes (1, "w") + bytes (2, "y") + bytes (4, "Conv"));
  const std::string input_x = bytes (11, bytes (1, "x"));
  EXPECT_NO_THROW (checkOnnxModelBytes (model (conv + input_x + bytes (5, tensor ({1}, bytes (9, std::string (4, '\0')))) + bytes (12, bytes (1, "y"))), "m"));
  refused (model (conv + input_x), "reads 'w', which nothing before it defines");
  refused (model (input_x + bytes (12, bytes (1, "z"))), "output 'z' is defined nowhere");
  const std::string good = model (bytes (5, tensor ({2}, bytes (9, std::string (8, '\0')))));
  refused (good.substr (0, good.size () - 3), "longer than the file");
  refused (number (1, 8), "no graph");
  refused ("\x0f", "wire type");
  refused (model (std::string ("\x08") + std::string (11, '\xff')), "longer than ten bytes");
}

TEST (ClassNames, BundledCocoList)
{
  const auto names = readClassNames (defaultClassNamesPath ());
  ASSERT_EQ (names.size (), 80u);
  EXPECT_EQ (names[0], "person");
  EXPECT_EQ (names[41], "cup");
  EXPECT_EQ (names[79], "toothbrush");
}

TEST (MaskFolderSegmenter, ReadsIdPNGsWithTheirJSONByNameOrIndex)
{
  test::TempDir dir;
  cv::Mat ids = cv::Mat::zeros (20, 30, CV_16U);
  ids (cv::Rect (2, 3, 5, 4)).setTo (7);
  ids (cv::Rect (10, 10, 6, 6)).setTo (3);
  io::writeImageAtomic (dir / "frame-000012.png", ids);
  test::writeFile (dir / "frame-000012.json",
                   R"({"instances": [{"id": 3, "class_id": 41, "score": 0.5}, {"id": 7, "class_id": 2, "class_name": "car", "score": 0.9}, {"id": 9, "class_id": 1}]})");
  io::writeImageAtomic (dir / "5.png", ids);  // matched by index, no JSON

  MaskFolderSegmenter folder (dir.str (), readClassNames (defaultClassNamesPath ()));
  RGBDFrame frame;
  frame.depth = cv::Mat::zeros (20, 30, CV_32F);
  frame.name = "frame-000012";
  frame.index = 99;
  std::vector<Instance> instances;
  ASSERT_TRUE (folder.segment (frame, instances));
  ASSERT_EQ (instances.size (), 2u);  // increasing id: 3, then 7; id 9 is not in the PNG
  EXPECT_EQ (instances[0].class_name, "cup");  // named from the class list
  EXPECT_FLOAT_EQ (instances[0].score, 0.5f);
  EXPECT_EQ (cv::countNonZero (instances[0].mask), 36);
  EXPECT_EQ (instances[1].class_name, "car");
  EXPECT_EQ (instances[1].box, cv::Rect (2, 3, 5, 4));

  frame.name = "something-else";
  frame.index = 12;  // falls back to the number in the stem
  ASSERT_TRUE (folder.segment (frame, instances));
  EXPECT_EQ (instances.size (), 2u);
  frame.index = 5;
  ASSERT_TRUE (folder.segment (frame, instances));
  EXPECT_EQ (instances[0].class_id, -1);
  EXPECT_FLOAT_EQ (instances[0].score, 1.f);
  frame.index = 6;
  EXPECT_FALSE (folder.segment (frame, instances));  // no masks: geometry only
  EXPECT_TRUE (instances.empty ());

  frame.index = 12;
  frame.depth = cv::Mat::zeros (21, 30, CV_32F);
  test::expectError ([&] { folder.segment (frame, instances); }, "frame-000012.png", "mask image is 30x20");
  frame.depth = cv::Mat::zeros (20, 30, CV_32F);
  test::writeFile (dir / "frame-000012.json", "{ broken");
  test::expectError ([&] { folder.segment (frame, instances); }, "frame-000012.json", "not valid JSON");
  // Ids are integers, class ids integers in range, scores probabilities.
  for (const auto& [entry, message] :
       {std::make_pair (R"({"id": 4.7})", "instance id 4.7 is not an integer"),
        std::make_pair (R"({"id": 3, "score": -5})", "score -5 of instance 3 is not in [0, 1]"),
        std::make_pair (R"({"id": 3, "score": 1e300})", "is not in [0, 1]"),
        std::make_pair (R"({"id": 3, "class_id": 1e20})", "class_id 1e+20 of instance 3 is not an integer"),
        std::make_pair (R"({"id": 3, "class_id": -7})", "is not an integer in [-1, 1000000]")})
  {
    test::writeFile (dir / "frame-000012.json", std::string (R"({"instances": [)") + entry + "]}");
    test::expectError ([&] { folder.segment (frame, instances); }, "frame-000012.json", message);
  }
  test::expectError ([&] { MaskFolderSegmenter bad (dir / "nope"); }, "nope", "not a folder");
}

TEST (MaskFolderSegmenter, ReadsTheSyntheticDetectorsMasks)
{
  test::TempDir dir;
  simulation::SyntheticSequenceConfig config;
  config.frames = 3;
  config.width = 160;
  config.height = 120;
  config.detector.boundary_px = 2;
  const simulation::SyntheticSequence sequence (simulation::SyntheticScene::load (test::tabletopScenePath ()), config);
  simulation::writeSyntheticSequence (sequence, io::DatasetLayout::Redwood, dir / "seq");
  const auto grabber = io::openDataset (dir / "seq");
  MaskFolderSegmenter folder (dir / "seq/detections");
  for (std::size_t i = 0; i < 3; ++i)
  {
    const RGBDFrame::Ptr frame = grabber->readFrame (i);
    const simulation::DetectionResult truth = sequence.detections (*sequence.frame (i));
    std::vector<Instance> instances;
    ASSERT_TRUE (folder.segment (*frame, instances)) << i;
    ASSERT_EQ (instances.size (), truth.detections.size ());
    for (std::size_t k = 0; k < instances.size (); ++k)
    {
      EXPECT_EQ (instances[k].class_name, truth.detections[k].class_name);
      EXPECT_NEAR (instances[k].score, truth.detections[k].score, 1e-5f);
      EXPECT_EQ (cv::countNonZero (instances[k].mask != (truth.ids == truth.detections[k].id) / 255), 0);
    }
  }
}

TEST_F (OnnxSegmenter, SegmentFrameRunsTheModel)
{
  // A 64×48 wall 1 m away, coloured: the model's boxes land on it as mask segments.
  pcl::PointCloud<pcl::PointXYZRGBA> wall (64, 48);
  for (int y = 0; y < 48; ++y)
    for (int x = 0; x < 64; ++x)
    {
      auto& p = wall (x, y);
      p.x = (x - 32) / 500.f;
      p.y = (y - 24) / 500.f;
      p.z = 1.f;
      p.r = p.g = p.b = 100;
    }
  ASSERT_EQ (pcl::io::savePCDFileBinary (dir / "wall.pcd", wall), 0);
  const std::string model = makeModel (dir, "v8", spec ("v8"));
  const auto r = test::runCuefusion ("segment-frame " + (dir / "wall.pcd") + " --out " + (dir / "out.pcd") + " --model " +
                                       model + " --classes " + (dir / "abc.names") + " --input-size 64 --mode masks",
                                     dir);
  ASSERT_EQ (r.code, 0) << r.err;
  pcl::PointCloud<pcl::PointXYZRGBL> out;
  ASSERT_EQ (pcl::io::loadPCDFile (dir / "out.pcd", out), 0);
  // Letterbox: 64×48 sits at rows 8–55 of the input. Instance B (highest score, on top)
  // covers input rows 40–55 of x 8–31 → frame rows 32–47; A input x 12–51, y 8–39 →
  // frame y 0–31.
  EXPECT_EQ (out (20, 40).label, 1u);  // B
  EXPECT_EQ (out (40, 10).label, 2u);  // A (D has A's box with a lower score: hidden)
  EXPECT_EQ (out (60, 40).label, 0u);
  const auto json = nlohmann::json::parse (test::readFile (dir / "out.json"));
  EXPECT_EQ (json.at ("segments").at (0).at ("class_name"), "gamma");
  EXPECT_EQ (json.at ("segments").at (1).at ("class_name"), "beta");
}

namespace
{
std::string
shippedModelPath ()
{
  return std::string (CUEFUSION_TEST_DATA_DIR) + "/models/xyz_instances.onnx";
}

/** Mean over the truth's objects (>= min_pixels visible) of the best IoU of one mask. */
double
meanBestIoU (const std::vector<Instance>& instances, const cv::Mat& truth, int min_pixels, int& objects)
{
  std::map<int, int> area;
  for (int v = 0; v < truth.rows; ++v)
    for (int u = 0; u < truth.cols; ++u)
      if (truth.at<std::uint16_t> (v, u))
        ++area[truth.at<std::uint16_t> (v, u)];
  double sum = 0;
  objects = 0;
  for (const auto& [id, pixels] : area)
  {
    if (pixels < min_pixels)
      continue;
    const cv::Mat object = truth == id;
    double best = 0;
    for (const Instance& instance : instances)
    {
      const cv::Mat mask = instance.mask > 0;
      const double inter = cv::countNonZero (object & mask), uni = cv::countNonZero (object | mask);
      best = std::max (best, uni > 0 ? inter / uni : 0.0);
    }
    sum += best;
    ++objects;
  }
  return objects ? sum / objects : 0.0;
}
}  // namespace

TEST (ShippedNetwork, MasksOfUnseenRenderedViewsMatchTheTruth)
{
  // Views the network never saw (another seed than training and validation), at 640×480
  // (it runs at 320 columns), and the bundled tabletop scene with depth noise.
  OnnxInstanceSegmenterConfig config;
  config.model_path = shippedModelPath ();
  OnnxInstanceSegmenter network (config);
  ASSERT_EQ (network.layout (), OnnxLayout::Xyz);
  double sum = 0;
  int views = 0, objects_seen = 0;
  const simulation::RandomSceneGenerator generator (simulation::RandomSceneConfig (), 424242);
  for (std::size_t i = 0; i < 8; ++i)
  {
    const simulation::RandomView view = generator.view (i, 640, 480);
    RGBDFrame frame;
    frame.camera = view.camera;
    frame.depth = view.view.depth;
    frame.color = view.view.color;
    std::vector<Instance> instances;
    ASSERT_TRUE (network.segment (frame, instances));
    int objects = 0;
    const double iou = meanBestIoU (instances, view.objects, 400, objects);
    if (!objects)
      continue;
    sum += iou;
    ++views;
    objects_seen += objects;
  }
  simulation::SyntheticSequenceConfig sequence_config;
  sequence_config.frames = 30;
  sequence_config.noise.enabled = true;
  const simulation::SyntheticScene scene = simulation::SyntheticScene::load (test::tabletopScenePath ());
  const simulation::SyntheticSequence sequence (scene, sequence_config);
  for (std::size_t i = 0; i < 30; i += 10)
  {
    const RGBDFrame::Ptr frame = sequence.frame (i);
    cv::Mat truth = frame->instance_mask.clone ();
    for (int v = 0; v < truth.rows; ++v)
      for (int u = 0; u < truth.cols; ++u)
      {
        const std::uint16_t id = truth.at<std::uint16_t> (v, u);
        if (id && !scene.objectById (id)->detectable)
          truth.at<std::uint16_t> (v, u) = 0;
      }
    std::vector<Instance> instances;
    ASSERT_TRUE (network.segment (*frame, instances));
    int objects = 0;
    sum += meanBestIoU (instances, truth, 400, objects);
    ++views;
    objects_seen += objects;
  }
  ASSERT_GE (views, 8);
  std::cout << "shipped network: mean best IoU " << sum / views << " over " << objects_seen << " objects in " << views
            << " views\n";
  EXPECT_GE (objects_seen, 30);
  EXPECT_GE (sum / views, 0.7) << "mean IoU over " << views << " views";
}

TEST (ShippedNetwork, RunAndSegmentFrameUseIt)
{
  test::TempDir dir;
  simulation::SyntheticSequenceConfig config;
  config.frames = 6;
  config.noise.enabled = true;
  simulation::writeSyntheticSequence (simulation::SyntheticSequence (simulation::SyntheticScene::load (test::tabletopScenePath ()), config),
                              io::DatasetLayout::Redwood, dir / "seq");
  // By name, from a folder outside the source tree (the data directory is looked up).
  const auto run = test::runCuefusion ("run seq --out run --model xyz_instances", dir, true);
  ASSERT_EQ (run.code, 0) << run.err;
  const auto segments = nlohmann::json::parse (test::readFile (dir / "run/segments.json")).at ("segments");
  int objects = 0;
  for (const auto& s : segments)
    objects += s.at ("class") == "object" ? 1 : 0;
  EXPECT_GE (objects, 5);  // the tabletop holds 8 objects

  // By the source tree's path, from that folder too (it holds no data/ of its own).
  const auto one = test::runCuefusion ("segment-frame seq/depth/00000.png --intrinsics seq/camera_intrinsics.json "
                                       "--out one.pcd --model data/models/xyz_instances.onnx --mode masks",
                                       dir, true);
  ASSERT_EQ (one.code, 0) << one.err;
  EXPECT_GE (nlohmann::json::parse (test::readFile (dir / "one.json")).at ("segments").size (), 5u);

  // A name that is no shipped network: one line naming it.
  const auto missing = test::runCuefusion ("segment-frame seq/depth/00000.png --intrinsics seq/camera_intrinsics.json "
                                           "--out two.pcd --model no_such_network",
                                           dir, true);
  EXPECT_NE (missing.code, 0);
  EXPECT_NE (missing.err.find ("no_such_network"), std::string::npos) << missing.err;
  EXPECT_NE (missing.err.find ("no such model file"), std::string::npos) << missing.err;
}
