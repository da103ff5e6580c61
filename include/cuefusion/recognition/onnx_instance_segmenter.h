// SPDX-License-Identifier: BSD-3-Clause
#pragma once

#include <cuefusion/recognition/instance_segmenter.h>

#include <opencv2/dnn.hpp>

#include <string>
#include <vector>

namespace cuefusion
{
namespace recognition
{
/** \brief Parameters of OnnxInstanceSegmenter. */
struct OnnxInstanceSegmenterConfig
{
  std::string model_path;             ///< an .onnx file (never downloaded), or a shipped network by name: "xyz_instances" (see findDataFile)
  std::string classes_path;           ///< class names, one per line, or a shipped list by name ("coco"); "" = data/classes/coco.names (YOLO layouts)
  int input_size = 640;               ///< square network input (letterboxed; YOLO layouts)
  int dense_width = 320;              ///< xyz layout: the frame is resampled to this width (the training scale)
  int min_mask_pixels = 100;          ///< xyz layout: smaller instances (frame pixels) are dropped
  float score_threshold = 0.25f;      ///< detections (xyz layout: instances by mean foreground) below are dropped
  float nms_threshold = 0.45f;        ///< IoU above which the lower-scored box of a class is dropped
  float mask_threshold = 0.5f;        ///< on sigmoid(coefficients · prototypes); xyz layout: on the foreground
  float boundary_threshold = 0.3f;    ///< xyz layout: instance boundary where its probability is at least this
                                      ///< (chosen on held-out synthetic views, tools/train_masks/calibrate.py)
  /// xyz layout: a mask's score is its mean foreground probability times its stability, the
  /// IoU with the mask it overlaps most when decoded at boundary_threshold − and + this
  /// (the stability score of Segment Anything, Kirillov et al. 2023): a mask that merges
  /// with a neighbour, or splits, when the cut moves a little is ranked lower. 0 = off.
  /// Chosen on held-out synthetic views (tools/train_masks/score_calibration.py).
  float stability_delta = 0.1f;
  /// xyz layouts: a mask wider than this across the view (metres: the span of the middle
  /// 90 % of its pixels' columns or rows, over 0.9, at their median depth) is dropped. The
  /// network was trained on objects of at most 0.28 m (RandomSceneConfig::max_size); a mask
  /// twice that wide is outside anything it saw — a run of wall cabinets, a shelf of books,
  /// a wall — and would unite what geometry keeps apart. 0 = keep every mask.
  float max_object_extent = 0.56f;
  int max_detections = 100;
  void validate () const;
};
/// The name before 0.2 (one config per class, named after it).
using OnnxSegmenterConfig [[deprecated ("renamed OnnxInstanceSegmenterConfig")]] = OnnxInstanceSegmenterConfig;

/** \brief The model layouts OnnxInstanceSegmenter recognises by their output shapes. */
enum class OnnxLayout
{
  V5,   ///< YOLOv5-seg: detections [1, N, 4 + 1 + C + K] (box, objectness, class scores, mask coefficients)
  V8,   ///< YOLOv8/11-seg: detections [1, 4 + C + K, N] (box, class scores, mask coefficients)
  Xyz,  ///< cuefusion's class-agnostic network: xyz [1, 3, H, W] in, logits [1, 2, H/2, W/2] out
        ///< (channel 0 foreground, channel 1 instance boundary), tools/train_masks
  XyzRgb  ///< the same network also given the colour: xyz and RGB [1, 6, H, W] in, the same out
};

/** \brief Where a frame sits in the letterboxed network input. */
struct Letterbox
{
  float scale = 1.f;   ///< input pixels per frame pixel
  int pad_x = 0, pad_y = 0;
  cv::Size frame;
};

/** \brief An instance segmentation network run on the CPU through OpenCV DNN
  * (`cv::dnn::readNetFromONNX`): a YOLO-seg export on the colour image, or cuefusion's own
  * class-agnostic network on the depth (data/models/xyz_instances.onnx).
  *
  * Xyz layout: depth → camera-frame xyz (0 where depth is missing), resampled (nearest) to
  * dense_width columns and padded to multiples of 16 → forward → decodeDense. Needs the
  * frame's depth and camera; every instance has class "object". XyzRgb layout: the same,
  * with the colour image (area-resampled, RGB / 255 − 0.5) as three more input channels;
  * needs the colour image too. The two are told apart by the input the model accepts.
  *
  * YOLO layouts:
  * Colour → letterbox (aspect kept, grey 114 padding) → RGB blob / 255 → forward →
  * candidates above score_threshold (YOLOv5: objectness × best class score) →
  * class-aware NMS (`cv::dnn::NMSBoxes` on boxes offset per class; OpenCV 4.6 has no
  * batched NMS) → per kept box mask = sigmoid(coefficients · prototypes), cut to the box,
  * scaled to the frame, thresholded. The layout is found from the output shapes and the
  * number of class names when the model is loaded (a dry run on a blank input); any
  * other layout is a cuefusion::Error naming the shapes found.
  *
  * OpenCV 4.6 (Debian bookworm) loads YOLOv5-seg exported at opset 12; it cannot load the
  * stock YOLOv8/11 exports or torchvision's Mask R-CNN (README, "Instance masks").
  */
class OnnxInstanceSegmenter : public InstanceSegmenter
{
public:
  /** \brief Loads the model and class names; throws cuefusion::Error naming the file. */
  explicit OnnxInstanceSegmenter (const OnnxInstanceSegmenterConfig& config);

  bool segment (const RGBDFrame& frame, std::vector<Instance>& instances) override;
  std::string name () const override;
  SegmenterTimings lastTimings () const override { return timings_; }

  OnnxLayout layout () const { return layout_; }
  const std::vector<std::string>& classNames () const { return class_names_; }

  /** \brief Letterbox \a color (BGR) into a square of \a size. */
  static cv::Mat letterbox (const cv::Mat& color, int size, Letterbox& box);

  /** \brief Instances from the network outputs (detections and prototypes, either order)
    * of one letterboxed frame. Throws cuefusion::Error on an unknown layout.
    */
  static std::vector<Instance> decode (const std::vector<cv::Mat>& outputs, const Letterbox& box,
                                       const OnnxInstanceSegmenterConfig& config,
                                       const std::vector<std::string>& class_names, OnnxLayout* layout = nullptr);

  /** \brief Instances from the xyz layout's output [1, 2, h, w] (logits). \a content is
    * the part of the output (from its top-left corner) that covers the frame, \a frame the
    * frame's size. Seeds = foreground > mask_threshold and boundary < boundary_threshold;
    * their 4-connected components are the instances (components smaller than
    * min_mask_pixels, counted in frame pixels, are dropped); labels then grow into the
    * rest of the foreground by up to 3 steps of a 3×3 maximum filter (the highest label
    * wins where two meet); each label, resized (nearest) to \a frame, is one mask, its score
    * the mean foreground probability (instances below score_threshold dropped) times its
    * stability (stability_delta), at most max_detections kept (highest scores).
    */
  static std::vector<Instance> decodeDense (const cv::Mat& output, cv::Size content, cv::Size frame,
                                            const OnnxInstanceSegmenterConfig& config);

  /** \brief The xyz layout's input for \a frame: [1, 3, H, W] blob and the size of the
    * frame inside it (top-left). Throws cuefusion::Error without depth.
    */
  static cv::Mat xyzInput (const RGBDFrame& frame, int dense_width, cv::Size& content);

  /** \brief The dense layouts' input: xyzInput, and for \a layout XyzRgb the colour image
    * (resized to the depth's size, then area-resampled like xyz) as channels 3–5, RGB
    * scaled to [−0.5, 0.5] as in tools/train_masks/train.py. Throws cuefusion::Error
    * without depth, or for XyzRgb without a CV_8UC3 colour image.
    */
  static cv::Mat denseInput (const RGBDFrame& frame, int dense_width, OnnxLayout layout, cv::Size& content);

  /** \brief Removes the \a instances wider than \a max_extent metres across the view: the
    * span between the 5th and 95th percentile of their pixels' columns (and rows) over 0.9
    * (a filled rectangle's width), times the median depth of those pixels over the focal
    * length (\a frame's depth and camera). Masks without depth are kept.
    * OnnxInstanceSegmenterConfig::max_object_extent.
    */
  static void dropWiderThan (const RGBDFrame& frame, float max_extent, std::vector<Instance>& instances);

private:
  OnnxInstanceSegmenterConfig config_;
  std::vector<std::string> class_names_;
  cv::dnn::Net net_;
  std::vector<std::string> output_names_;
  OnnxLayout layout_ = OnnxLayout::V5;
  SegmenterTimings timings_;
};
}  // namespace recognition
}  // namespace cuefusion
