#include <cuefusion/common/exceptions.h>
#include <cuefusion/recognition/onnx_instance_segmenter.h>

#include <boost/filesystem.hpp>

#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cmath>
#include <sstream>

namespace cuefusion
{
namespace recognition
{
namespace
{
std::string
shapeOf (const cv::Mat& m)
{
  std::ostringstream out;
  out << "[";
  for (int d = 0; d < m.dims; ++d)
    out << (d ? ", " : "") << m.size[d];
  out << "]";
  return out.str ();
}

struct Candidate
{
  cv::Rect2d box;      ///< in network input pixels
  int class_id;
  float score;
  int row;             ///< detection index, for the mask coefficients
};
}  // namespace

void
OnnxSegmenterConfig::validate () const
{
  if (input_size < 32 || input_size > 4096 || input_size % 32 != 0)
    throw ParameterError ("--input-size", "must be a multiple of 32 in [32, 4096]");
  for (const auto& [value, option] :
       {std::make_pair (score_threshold, "--score-threshold"), std::make_pair (nms_threshold, "--nms-threshold"),
        std::make_pair (mask_threshold, "--mask-threshold")})
    if (!(std::isfinite (value) && value >= 0.f && value <= 1.f))
      throw ParameterError (option, "must lie in [0, 1]");
  if (max_detections < 1)
    throw ParameterError ("--max-detections", "must be at least 1");
}

cv::Mat
OnnxInstanceSegmenter::letterbox (const cv::Mat& color, int size, Letterbox& box)
{
  box.frame = color.size ();
  box.scale = std::min (static_cast<float> (size) / static_cast<float> (color.cols),
                        static_cast<float> (size) / static_cast<float> (color.rows));
  const int width = std::max (1, static_cast<int> (std::lround (color.cols * box.scale)));
  const int height = std::max (1, static_cast<int> (std::lround (color.rows * box.scale)));
  box.pad_x = (size - width) / 2;
  box.pad_y = (size - height) / 2;
  cv::Mat input (size, size, CV_8UC3, cv::Scalar (114, 114, 114));
  cv::Mat resized;
  cv::resize (color, resized, cv::Size (width, height), 0, 0, cv::INTER_LINEAR);
  resized.copyTo (input (cv::Rect (box.pad_x, box.pad_y, width, height)));
  return input;
}

std::vector<Instance>
OnnxInstanceSegmenter::decode (const std::vector<cv::Mat>& outputs, const Letterbox& box,
                               const OnnxSegmenterConfig& config, const std::vector<std::string>& class_names,
                               YoloSegLayout* layout_out)
{
  const cv::Mat* det = nullptr;
  const cv::Mat* protos = nullptr;
  std::string shapes;
  for (const cv::Mat& m : outputs)
  {
    shapes += (shapes.empty () ? "" : " and ") + shapeOf (m);
    if (m.dims == 4 && m.size[0] == 1)
      protos = &m;
    else if (m.dims == 3 && m.size[0] == 1)
      det = &m;
  }
  const int classes = static_cast<int> (class_names.size ());
  const std::string expected = "expected YOLO-seg outputs: detections [1, N, 5+C+K] (YOLOv5) or [1, 4+C+K, N] "
                               "(YOLOv8/11) and prototypes [1, K, H/4, W/4], with C = " +
                               std::to_string (classes) + " class names";
  if (outputs.size () != 2 || !det || !protos)
    throw Error ("ONNX model", "outputs " + shapes + " do not match the layout: " + expected);
  const int k = protos->size[1], mh = protos->size[2], mw = protos->size[3];
  YoloSegLayout layout;
  int n = 0;
  if (det->size[2] == 5 + classes + k)
  {
    layout = YoloSegLayout::V5;
    n = det->size[1];
  }
  else if (det->size[1] == 4 + classes + k)
  {
    layout = YoloSegLayout::V8;
    n = det->size[2];
  }
  else
    throw Error ("ONNX model", "outputs " + shapes + " do not match the layout: " + expected);
  if (layout_out)
    *layout_out = layout;
  CV_Assert (det->type () == CV_32F && protos->type () == CV_32F && det->isContinuous () && protos->isContinuous ());
  const float* data = det->ptr<float> ();
  const int width = layout == YoloSegLayout::V5 ? 5 + classes + k : 4 + classes + k;
  auto at = [&] (int row, int attribute) {
    return layout == YoloSegLayout::V5 ? data[static_cast<std::size_t> (row) * width + attribute]
                                       : data[static_cast<std::size_t> (attribute) * n + row];
  };
  const int class0 = layout == YoloSegLayout::V5 ? 5 : 4, coefficient0 = class0 + classes;

  // Candidates, then class-aware NMS: boxes of different classes are moved far apart.
  std::vector<Candidate> candidates;
  for (int row = 0; row < n; ++row)
  {
    int best = 0;
    for (int c = 1; c < classes; ++c)
      if (at (row, class0 + c) > at (row, class0 + best))
        best = c;
    const float score = at (row, class0 + best) * (layout == YoloSegLayout::V5 ? at (row, 4) : 1.f);
    if (!(score >= config.score_threshold))
      continue;
    const double cx = at (row, 0), cy = at (row, 1), w = at (row, 2), h = at (row, 3);
    candidates.push_back ({cv::Rect2d (cx - w / 2, cy - h / 2, w, h), best, score, row});
  }
  std::vector<cv::Rect2d> shifted;
  std::vector<float> scores;
  const double offset = 4.0 * config.input_size;
  for (const Candidate& c : candidates)
  {
    shifted.emplace_back (c.box.x + c.class_id * offset, c.box.y + c.class_id * offset, c.box.width, c.box.height);
    scores.push_back (c.score);
  }
  std::vector<int> keep;
  cv::dnn::NMSBoxes (shifted, scores, config.score_threshold, config.nms_threshold, keep, 1.f, config.max_detections);

  const cv::Mat prototypes (k, mh * mw, CV_32F, const_cast<float*> (protos->ptr<float> ()));
  const cv::Rect frame_rect (cv::Point (0, 0), box.frame);
  const cv::Rect content (box.pad_x, box.pad_y, static_cast<int> (std::lround (box.frame.width * box.scale)),
                          static_cast<int> (std::lround (box.frame.height * box.scale)));
  std::vector<Instance> instances;
  for (const int index : keep)
  {
    const Candidate& c = candidates[static_cast<std::size_t> (index)];
    cv::Mat coefficients (1, k, CV_32F);
    for (int j = 0; j < k; ++j)
      coefficients.at<float> (0, j) = at (c.row, coefficient0 + j);
    cv::Mat logits = coefficients * prototypes, probability;
    cv::exp (-logits, probability);
    probability = 1.0 / (1.0 + probability);  // sigmoid
    cv::Mat input_mask, frame_mask;
    cv::resize (probability.reshape (1, mh), input_mask, cv::Size (config.input_size, config.input_size), 0, 0,
                cv::INTER_LINEAR);
    cv::resize (input_mask (content & cv::Rect (0, 0, config.input_size, config.input_size)), frame_mask, box.frame, 0, 0,
                cv::INTER_LINEAR);
    // The box in frame pixels, rounded outwards; the mask is cut to it.
    const double x0 = (c.box.x - box.pad_x) / box.scale, y0 = (c.box.y - box.pad_y) / box.scale;
    const double x1 = (c.box.x + c.box.width - box.pad_x) / box.scale, y1 = (c.box.y + c.box.height - box.pad_y) / box.scale;
    const cv::Rect frame_box = cv::Rect (cv::Point (static_cast<int> (std::floor (x0)), static_cast<int> (std::floor (y0))),
                                         cv::Point (static_cast<int> (std::ceil (x1)), static_cast<int> (std::ceil (y1)))) &
                               frame_rect;
    Instance instance;
    instance.mask = cv::Mat::zeros (box.frame, CV_8U);
    if (frame_box.area () > 0)
      instance.mask (frame_box).setTo (1, frame_mask (frame_box) > config.mask_threshold);
    instance.box = frame_box;
    instance.class_id = c.class_id;
    instance.class_name = class_names[static_cast<std::size_t> (c.class_id)];
    instance.score = c.score;
    if (cv::countNonZero (instance.mask) > 0)
      instances.push_back (std::move (instance));
  }
  return instances;
}

OnnxInstanceSegmenter::OnnxInstanceSegmenter (const OnnxSegmenterConfig& config) : config_ (config)
{
  config_.validate ();
  if (config_.classes_path.empty ())
    config_.classes_path = defaultClassNamesPath ();
  class_names_ = readClassNames (config_.classes_path);
  boost::system::error_code ec;
  if (!boost::filesystem::is_regular_file (config_.model_path, ec))
    throw Error (config_.model_path, "no such model file");
  try
  {
    net_ = cv::dnn::readNetFromONNX (config_.model_path);
  }
  catch (const cv::Exception& e)
  {
    std::string what = e.what ();
    std::replace (what.begin (), what.end (), '\n', ' ');
    throw Error (config_.model_path, "OpenCV DNN cannot load this model (" + what.substr (0, 300) + ")");
  }
  if (net_.empty ())
    throw Error (config_.model_path, "OpenCV DNN read an empty network");
  net_.setPreferableBackend (cv::dnn::DNN_BACKEND_OPENCV);
  net_.setPreferableTarget (cv::dnn::DNN_TARGET_CPU);
  output_names_ = net_.getUnconnectedOutLayersNames ();
  // Dry run on a blank frame: the layout is known (or refused) before the first frame.
  std::vector<cv::Mat> outputs;
  try
  {
    const cv::Mat blank (config_.input_size, config_.input_size, CV_8UC3, cv::Scalar (114, 114, 114));
    net_.setInput (cv::dnn::blobFromImage (blank, 1.0 / 255.0, cv::Size (), cv::Scalar (), true, false));
    net_.forward (outputs, output_names_);
  }
  catch (const cv::Exception& e)
  {
    std::string what = e.what ();
    std::replace (what.begin (), what.end (), '\n', ' ');
    throw Error (config_.model_path, "OpenCV DNN cannot run this model at " + std::to_string (config_.input_size) +
                                       "x" + std::to_string (config_.input_size) + " (" + what.substr (0, 300) + ")");
  }
  Letterbox box;
  box.frame = cv::Size (config_.input_size, config_.input_size);
  try
  {
    decode (outputs, box, config_, class_names_, &layout_);
  }
  catch (const Error& e)
  {
    throw Error (config_.model_path, e.what ());
  }
}

std::string
OnnxInstanceSegmenter::name () const
{
  return "onnx:" + boost::filesystem::path (config_.model_path).filename ().string () +
         (layout_ == YoloSegLayout::V5 ? " (YOLOv5-seg layout)" : " (YOLOv8-seg layout)");
}

bool
OnnxInstanceSegmenter::segment (const RGBDFrame& frame, std::vector<Instance>& instances)
{
  if (frame.color.empty () || frame.color.type () != CV_8UC3)
    throw Error ("OnnxInstanceSegmenter", "needs a CV_8UC3 colour image");
  Letterbox box;
  const cv::Mat input = letterbox (frame.color, config_.input_size, box);
  net_.setInput (cv::dnn::blobFromImage (input, 1.0 / 255.0, cv::Size (), cv::Scalar (), true, false));
  std::vector<cv::Mat> outputs;
  net_.forward (outputs, output_names_);
  instances = decode (outputs, box, config_, class_names_);
  return true;
}
}  // namespace recognition
}  // namespace cuefusion
