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
struct OnnxSegmenterConfig
{
  std::string model_path;             ///< the user's .onnx file (never downloaded)
  std::string classes_path;           ///< class names, one per line; "" = data/classes/coco.names
  int input_size = 640;               ///< square network input (letterboxed)
  float score_threshold = 0.25f;      ///< detections below are dropped
  float nms_threshold = 0.45f;        ///< IoU above which the lower-scored box of a class is dropped
  float mask_threshold = 0.5f;        ///< on sigmoid(coefficients · prototypes)
  int max_detections = 100;
  void validate () const;
};

/** \brief The two YOLO segmentation export layouts. */
enum class YoloSegLayout
{
  V5,  ///< detections [1, N, 4 + 1 + C + K]: box, objectness, class scores, mask coefficients
  V8   ///< detections [1, 4 + C + K, N]: box, class scores, mask coefficients (YOLOv8 / YOLO11)
};

/** \brief Where a frame sits in the letterboxed network input. */
struct Letterbox
{
  float scale = 1.f;   ///< input pixels per frame pixel
  int pad_x = 0, pad_y = 0;
  cv::Size frame;
};

/** \brief A YOLO segmentation network (YOLOv5-seg, YOLOv8/11-seg export layouts) run on
  * the CPU through OpenCV DNN (`cv::dnn::readNetFromONNX`).
  *
  * Colour → letterbox (aspect kept, grey 114 padding) → RGB blob / 255 → forward →
  * candidates above score_threshold (YOLOv5: objectness × best class score) →
  * class-aware NMS (`cv::dnn::NMSBoxes` on boxes offset per class; OpenCV 4.6 has no
  * batched NMS) → per kept box mask = sigmoid(coefficients · prototypes), cut to the box,
  * scaled to the frame, thresholded. The layout is found from the output shapes and the
  * number of class names when the model is loaded (a dry run on a blank image); any
  * other layout is a cuefusion::Error naming the shapes found.
  *
  * OpenCV 4.6 (Debian bookworm) loads YOLOv5-seg exported at opset 12; it cannot load the
  * stock YOLOv8/11 exports or torchvision's Mask R-CNN (README, "Instance masks").
  */
class OnnxInstanceSegmenter : public InstanceSegmenter
{
public:
  /** \brief Loads the model and class names; throws cuefusion::Error naming the file. */
  explicit OnnxInstanceSegmenter (const OnnxSegmenterConfig& config);

  bool segment (const RGBDFrame& frame, std::vector<Instance>& instances) override;
  std::string name () const override;

  YoloSegLayout layout () const { return layout_; }
  const std::vector<std::string>& classNames () const { return class_names_; }

  /** \brief Letterbox \a color (BGR) into a square of \a size. */
  static cv::Mat letterbox (const cv::Mat& color, int size, Letterbox& box);

  /** \brief Instances from the network outputs (detections and prototypes, either order)
    * of one letterboxed frame. Throws cuefusion::Error on an unknown layout.
    */
  static std::vector<Instance> decode (const std::vector<cv::Mat>& outputs, const Letterbox& box,
                                       const OnnxSegmenterConfig& config,
                                       const std::vector<std::string>& class_names, YoloSegLayout* layout = nullptr);

private:
  OnnxSegmenterConfig config_;
  std::vector<std::string> class_names_;
  cv::dnn::Net net_;
  std::vector<std::string> output_names_;
  YoloSegLayout layout_ = YoloSegLayout::V5;
};
}  // namespace recognition
}  // namespace cuefusion
