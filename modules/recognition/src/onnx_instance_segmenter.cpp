// SPDX-License-Identifier: BSD-3-Clause
#include <cuefusion/common/data_directory.h>
#include <cuefusion/common/exceptions.h>
#include <cuefusion/common/quiet_opencv_log.h>
#include <cuefusion/recognition/onnx_instance_segmenter.h>
#include <cuefusion/recognition/onnx_model_check.h>

#include <boost/filesystem.hpp>

#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <chrono>
#include <climits>
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
OnnxInstanceSegmenterConfig::validate () const
{
  if (input_size < 32 || input_size > 4096 || input_size % 32 != 0)
    throw ParameterError ("OnnxInstanceSegmenterConfig::input_size", "must be a multiple of 32 in [32, 4096]");
  for (const auto& [value, field] :
       {std::make_pair (score_threshold, "score_threshold"), std::make_pair (nms_threshold, "nms_threshold"),
        std::make_pair (mask_threshold, "mask_threshold"), std::make_pair (boundary_threshold, "boundary_threshold")})
    if (!(std::isfinite (value) && value >= 0.f && value <= 1.f))
      throw ParameterError (std::string ("OnnxInstanceSegmenterConfig::") + field, "must lie in [0, 1]");
  if (!(std::isfinite (stability_delta) && stability_delta >= 0.f && stability_delta <= 0.5f))
    throw ParameterError ("OnnxInstanceSegmenterConfig::stability_delta", "must lie in [0, 0.5]");
  if (max_detections < 1)
    throw ParameterError ("OnnxInstanceSegmenterConfig::max_detections", "must be at least 1");
  if (dense_width < 16 || dense_width > 4096)
    throw ParameterError ("OnnxInstanceSegmenterConfig::dense_width", "must lie in [16, 4096] pixels");
  if (min_mask_pixels < 0)
    throw ParameterError ("OnnxInstanceSegmenterConfig::min_mask_pixels", "must not be negative");
  if (!(std::isfinite (max_object_extent) && max_object_extent >= 0.f))
    throw ParameterError ("OnnxInstanceSegmenterConfig::max_object_extent", "must be a finite length of at least 0 (m; 0 = off)");
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
                               const OnnxInstanceSegmenterConfig& config, const std::vector<std::string>& class_names,
                               OnnxLayout* layout_out)
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
                               std::to_string (classes) + " class names; or one output [1, 2, H/2, W/2] (xyz layout)";
  if (outputs.size () != 2 || !det || !protos)
    throw Error ("ONNX model", "outputs " + shapes + " do not match the layout: " + expected);
  const int k = protos->size[1], mh = protos->size[2], mw = protos->size[3];
  OnnxLayout layout;
  int n = 0;
  if (det->size[2] == 5 + classes + k)
  {
    layout = OnnxLayout::V5;
    n = det->size[1];
  }
  else if (det->size[1] == 4 + classes + k)
  {
    layout = OnnxLayout::V8;
    n = det->size[2];
  }
  else
    throw Error ("ONNX model", "outputs " + shapes + " do not match the layout: " + expected);
  if (layout_out)
    *layout_out = layout;
  CV_Assert (det->type () == CV_32F && protos->type () == CV_32F && det->isContinuous () && protos->isContinuous ());
  const float* data = det->ptr<float> ();
  const int width = layout == OnnxLayout::V5 ? 5 + classes + k : 4 + classes + k;
  auto at = [&] (int row, int attribute) {
    return layout == OnnxLayout::V5 ? data[static_cast<std::size_t> (row) * width + attribute]
                                       : data[static_cast<std::size_t> (attribute) * n + row];
  };
  const int class0 = layout == OnnxLayout::V5 ? 5 : 4, coefficient0 = class0 + classes;

  // Candidates, then class-aware NMS: boxes of different classes are moved far apart.
  std::vector<Candidate> candidates;
  for (int row = 0; row < n; ++row)
  {
    int best = 0;
    for (int c = 1; c < classes; ++c)
      if (at (row, class0 + c) > at (row, class0 + best))
        best = c;
    const float score = at (row, class0 + best) * (layout == OnnxLayout::V5 ? at (row, 4) : 1.f);
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

cv::Mat
OnnxInstanceSegmenter::xyzInput (const RGBDFrame& frame, int dense_width, cv::Size& content)
{
  if (frame.depth.empty () || frame.depth.type () != CV_32F)
    throw Error ("OnnxInstanceSegmenter", "the xyz layout needs the frame's depth (CV_32F metres)");
  const PinholeCamera& camera = frame.camera;
  if (camera.width != frame.depth.cols || camera.height != frame.depth.rows || !(camera.fx > 0.0) || !(camera.fy > 0.0))
    throw Error ("OnnxInstanceSegmenter", "the frame's camera does not describe its " + std::to_string (frame.depth.cols) +
                                            "x" + std::to_string (frame.depth.rows) + " depth image");
  cv::Mat xyz (frame.depth.size (), CV_32FC3);
  for (int v = 0; v < xyz.rows; ++v)
  {
    const float* z = frame.depth.ptr<float> (v);
    cv::Vec3f* out = xyz.ptr<cv::Vec3f> (v);
    for (int u = 0; u < xyz.cols; ++u)
    {
      const Eigen::Vector3f p = isValidDepth (z[u]) ? camera.backProject (static_cast<float> (u), static_cast<float> (v), z[u])
                                                     : Eigen::Vector3f::Zero ();
      out[u] = cv::Vec3f (p.x (), p.y (), p.z ());
    }
  }
  // Nearest resampling keeps every value a measured point (no mixing across depth jumps);
  // at half size input pixel (x, y) is frame pixel (2x, 2y), as the training views are rendered.
  const double scale = static_cast<double> (dense_width) / xyz.cols;
  content = cv::Size (dense_width, std::max (1, static_cast<int> (std::lround (xyz.rows * scale))));
  cv::Mat resized;
  cv::resize (xyz, resized, content, 0, 0, cv::INTER_NEAREST);
  cv::Mat padded = cv::Mat::zeros ((content.height + 15) / 16 * 16, (content.width + 15) / 16 * 16, CV_32FC3);
  resized.copyTo (padded (cv::Rect (cv::Point (0, 0), content)));
  return cv::dnn::blobFromImage (padded, 1.0, cv::Size (), cv::Scalar (), false, false, CV_32F);
}

cv::Mat
OnnxInstanceSegmenter::denseInput (const RGBDFrame& frame, int dense_width, OnnxLayout layout, cv::Size& content)
{
  const cv::Mat xyz = xyzInput (frame, dense_width, content);
  if (layout != OnnxLayout::XyzRgb)
    return xyz;
  if (frame.color.empty () || frame.color.type () != CV_8UC3)
    throw Error ("OnnxInstanceSegmenter", "the xyz and colour layout needs the frame's colour image (CV_8UC3)");
  cv::Mat color = frame.color;
  if (color.size () != frame.depth.size ())
    cv::resize (color, color, frame.depth.size (), 0, 0, cv::INTER_LINEAR);
  // Area resampling averages the colour a camera integrates over the coarser pixel (the
  // training views are rendered at this scale); RGB / 255 - 0.5 as train.py's network_input.
  cv::Mat small;
  cv::resize (color, small, content, 0, 0, cv::INTER_AREA);
  cv::Mat rgb;
  small.convertTo (rgb, CV_32FC3, 1.0 / 255.0, -0.5);
  const int rows = xyz.size[2], cols = xyz.size[3];
  const int shape[] = {1, 6, rows, cols};
  cv::Mat blob (4, shape, CV_32F, cv::Scalar (0.f));
  for (int c = 0; c < 3; ++c)
    std::copy (xyz.ptr<float> (0, c), xyz.ptr<float> (0, c) + rows * cols, blob.ptr<float> (0, c));
  for (int v = 0; v < content.height; ++v)
  {
    const cv::Vec3f* in = rgb.ptr<cv::Vec3f> (v);
    for (int c = 0; c < 3; ++c)
    {
      float* out = blob.ptr<float> (0, 3 + c) + v * cols;
      for (int u = 0; u < content.width; ++u)
        out[u] = in[u][2 - c];  // BGR → RGB
    }
  }
  return blob;
}

namespace
{
/** The xyz decoder's labels at one boundary threshold: seeds = \a foreground and boundary
  * below \a boundary_threshold; their 4-connected components of at least
  * \a min_frame_pixels (an output pixel being \a frame_per_output frame pixels) are
  * numbered 1..\a kept in scan order; labels then grow into the rest of the foreground by
  * up to 3 steps (the highest 3×3 neighbour label wins). */
cv::Mat
denseLabels (const cv::Mat& foreground, const cv::Mat& boundary_p, float boundary_threshold, double frame_per_output,
             int min_frame_pixels, int& kept)
{
  const cv::Mat seeds = foreground & (boundary_p < boundary_threshold);
  cv::Mat components, stats, centroids;
  const int count = cv::connectedComponentsWithStats (seeds, components, stats, centroids, 4, CV_32S);
  std::vector<int> renumber (static_cast<std::size_t> (count), 0);
  kept = 0;
  for (int c = 1; c < count; ++c)
    if (stats.at<int> (c, cv::CC_STAT_AREA) * frame_per_output >= min_frame_pixels)
      renumber[static_cast<std::size_t> (c)] = ++kept;
  cv::Mat labels (foreground.size (), CV_32S);
  for (int y = 0; y < labels.rows; ++y)
    for (int x = 0; x < labels.cols; ++x)
      labels.at<int> (y, x) = renumber[static_cast<std::size_t> (components.at<int> (y, x))];
  // Grow into the boundary band: unlabelled foreground takes the highest 3×3 neighbour label.
  for (int step = 0; step < 3; ++step)
  {
    const cv::Mat previous = labels.clone ();
    bool changed = false;
    for (int y = 0; y < labels.rows; ++y)
      for (int x = 0; x < labels.cols; ++x)
      {
        if (previous.at<int> (y, x) || !foreground.at<std::uint8_t> (y, x))
          continue;
        int best = 0;
        for (int dy = -1; dy <= 1; ++dy)
          for (int dx = -1; dx <= 1; ++dx)
          {
            const int yy = y + dy, xx = x + dx;
            if (yy >= 0 && yy < labels.rows && xx >= 0 && xx < labels.cols)
              best = std::max (best, previous.at<int> (yy, xx));
          }
        if (best)
        {
          labels.at<int> (y, x) = best;
          changed = true;
        }
      }
    if (!changed)
      break;
  }
  return labels;
}

/** For each label 1..\a count of \a labels: its IoU with the label of \a other it overlaps
  * most (the first such label on a tie; 0 when it overlaps none). */
std::vector<double>
bestMatchIoU (const cv::Mat& labels, int count, const cv::Mat& other, int other_count)
{
  const auto n = static_cast<std::size_t> (count) + 1, m = static_cast<std::size_t> (other_count) + 1;
  std::vector<int> overlap (n * m, 0), size (n, 0), other_size (m, 0);
  for (int y = 0; y < labels.rows; ++y)
    for (int x = 0; x < labels.cols; ++x)
    {
      const auto k = static_cast<std::size_t> (labels.at<int> (y, x)), j = static_cast<std::size_t> (other.at<int> (y, x));
      ++overlap[k * m + j];
      ++size[k];
      ++other_size[j];
    }
  std::vector<double> iou (n, 0.0);
  for (std::size_t k = 1; k < n; ++k)
  {
    std::size_t best = 0;
    for (std::size_t j = 1; j < m; ++j)
      if (overlap[k * m + j] > overlap[k * m + best])
        best = j;
    if (best)
    {
      const double o = overlap[k * m + best];
      iou[k] = o / (size[k] + other_size[best] - o);
    }
  }
  return iou;
}
}  // namespace

std::vector<Instance>
OnnxInstanceSegmenter::decodeDense (const cv::Mat& output, cv::Size content, cv::Size frame, const OnnxInstanceSegmenterConfig& config)
{
  if (output.dims != 4 || output.size[0] != 1 || output.size[1] != 2 || output.type () != CV_32F || !output.isContinuous ())
    throw Error ("ONNX model", "output " + shapeOf (output) + " is not the xyz layout [1, 2, H, W]");
  const int h = output.size[2], w = output.size[3];
  if (content.width < 1 || content.height < 1 || content.width > w || content.height > h || frame.area () == 0)
    throw Error ("ONNX model", "output " + shapeOf (output) + " does not cover the frame");
  const cv::Rect roi (cv::Point (0, 0), content);
  auto probability = [&] (int channel) {
    const cv::Mat logits (h, w, CV_32F, const_cast<float*> (output.ptr<float> ()) + static_cast<std::size_t> (channel) * h * w);
    cv::Mat p;
    cv::exp (-logits (roi), p);
    return cv::Mat (1.0 / (1.0 + p));
  };
  const cv::Mat foreground_p = probability (0), boundary_p = probability (1);
  const cv::Mat foreground = foreground_p > config.mask_threshold;
  const double frame_per_output = static_cast<double> (frame.area ()) / content.area ();
  int kept = 0;
  const cv::Mat labels = denseLabels (foreground, boundary_p, config.boundary_threshold, frame_per_output, config.min_mask_pixels, kept);
  // Score = mean foreground probability over the grown label (the threshold applies to
  // it), times its stability when stability_delta > 0.
  std::vector<double> score (static_cast<std::size_t> (kept) + 1, 0.0);
  std::vector<int> pixels (static_cast<std::size_t> (kept) + 1, 0);
  for (int y = 0; y < content.height; ++y)
    for (int x = 0; x < content.width; ++x)
    {
      const auto k = static_cast<std::size_t> (labels.at<int> (y, x));
      score[k] += foreground_p.at<float> (y, x);
      ++pixels[k];
    }
  std::vector<double> stability (static_cast<std::size_t> (kept) + 1, 1.0);
  if (config.stability_delta > 0.f)
    for (const float threshold : {config.boundary_threshold - config.stability_delta, config.boundary_threshold + config.stability_delta})
    {
      int other_count = 0;
      const cv::Mat other = denseLabels (foreground, boundary_p, threshold, frame_per_output, config.min_mask_pixels, other_count);
      const std::vector<double> iou = bestMatchIoU (labels, kept, other, other_count);
      for (std::size_t k = 1; k < stability.size (); ++k)
        stability[k] = std::min (stability[k], iou[k]);
    }
  std::vector<int> order;
  for (int k = 1; k <= kept; ++k)
  {
    double& s = score[static_cast<std::size_t> (k)];
    s /= pixels[static_cast<std::size_t> (k)];
    if (s < config.score_threshold)
      continue;
    s *= stability[static_cast<std::size_t> (k)];
    order.push_back (k);
  }
  std::stable_sort (order.begin (), order.end (),
                    [&score] (int a, int b) { return score[static_cast<std::size_t> (a)] > score[static_cast<std::size_t> (b)]; });
  if (order.size () > static_cast<std::size_t> (config.max_detections))
    order.resize (static_cast<std::size_t> (config.max_detections));
  cv::Mat frame_labels;
  cv::resize (labels, frame_labels, frame, 0, 0, cv::INTER_NEAREST);
  // Each label's box in one pass over the frame; a mask is then compared within its box
  // only (a pass over the whole frame per instance was most of the decoding).
  std::vector<cv::Rect> boxes (static_cast<std::size_t> (kept) + 1);
  {
    std::vector<int> x0 (boxes.size (), INT_MAX), y0 (boxes.size (), INT_MAX), x1 (boxes.size (), -1), y1 (boxes.size (), -1);
    for (int y = 0; y < frame_labels.rows; ++y)
    {
      const std::int32_t* row = frame_labels.ptr<std::int32_t> (y);
      for (int x = 0; x < frame_labels.cols; ++x)
        if (row[x] > 0)
        {
          const auto k = static_cast<std::size_t> (row[x]);
          x0[k] = std::min (x0[k], x), x1[k] = std::max (x1[k], x);
          y0[k] = std::min (y0[k], y), y1[k] = std::max (y1[k], y);
        }
    }
    for (std::size_t k = 1; k < boxes.size (); ++k)
      if (x1[k] >= 0)
        boxes[k] = cv::Rect (x0[k], y0[k], x1[k] - x0[k] + 1, y1[k] - y0[k] + 1);
  }
  std::vector<Instance> instances;
  for (const int k : order)
  {
    Instance instance;
    instance.box = boxes[static_cast<std::size_t> (k)];
    if (instance.box.area () == 0)
      continue;
    instance.mask = cv::Mat::zeros (frame, CV_8U);
    instance.mask (instance.box).setTo (1, frame_labels (instance.box) == k);
    instance.class_id = 0;
    instance.class_name = "object";
    instance.score = static_cast<float> (score[static_cast<std::size_t> (k)]);
    instances.push_back (std::move (instance));
  }
  return instances;
}

OnnxInstanceSegmenter::OnnxInstanceSegmenter (const OnnxInstanceSegmenterConfig& config) : config_ (config)
{
  config_.validate ();
  // A shipped network by name (xyz_instances) or by its source-tree path from anywhere.
  config_.model_path = findDataFile (config_.model_path, "models", ".onnx");
  config_.classes_path = findDataFile (config_.classes_path, "classes", ".names");
  boost::system::error_code ec;
  if (!boost::filesystem::is_regular_file (config_.model_path, ec))
    throw Error (config_.model_path, "no such model file (nor a network of that name in " + dataDirectory () + "/models)");
  checkOnnxModel (config_.model_path);  // OpenCV's importer crashes on some malformed files
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
  // Dry run on a blank input: the layout is known (or refused) before the first frame. A
  // model that refuses three input channels is tried with six (xyz and colour).
  std::vector<cv::Mat> outputs;
  bool six_channels = false;
  auto oneLine = [] (const cv::Exception& e) {
    std::string what = e.what ();
    std::replace (what.begin (), what.end (), '\n', ' ');
    return what.substr (0, 300);
  };
  // OpenCV DNN logs a refused input shape on stderr before it throws: silent while we
  // probe (the error that matters comes back as one line).
  {
    const QuietOpenCVLog quiet;
    try
    {
      const cv::Mat blank (config_.input_size, config_.input_size, CV_8UC3, cv::Scalar (114, 114, 114));
      net_.setInput (cv::dnn::blobFromImage (blank, 1.0 / 255.0, cv::Size (), cv::Scalar (), true, false));
      net_.forward (outputs, output_names_);
    }
    catch (const cv::Exception& e)
    {
      const std::string three = oneLine (e);
      try
      {
        const int shape[] = {1, 6, config_.input_size, config_.input_size};
        net_.setInput (cv::Mat (4, shape, CV_32F, cv::Scalar (0.f)));
        net_.forward (outputs, output_names_);
        six_channels = true;
      }
      catch (const cv::Exception&)
      {
        throw Error (config_.model_path, "OpenCV DNN cannot run this model at " + std::to_string (config_.input_size) +
                                           "x" + std::to_string (config_.input_size) + " (" + three + ")");
      }
    }
  }
  if (outputs.size () == 1 && outputs[0].dims == 4 && outputs[0].size[0] == 1 && outputs[0].size[1] == 2 &&
      outputs[0].size[2] * 2 == config_.input_size && outputs[0].size[3] * 2 == config_.input_size)
  {
    layout_ = six_channels ? OnnxLayout::XyzRgb : OnnxLayout::Xyz;
    class_names_ = {"object"};
    return;
  }
  if (six_channels)
  {
    std::string shapes;
    for (const cv::Mat& m : outputs)
      shapes += (shapes.empty () ? "" : " and ") + shapeOf (m);
    throw Error (config_.model_path, "a model with 6 input channels must have one output [1, 2, H/2, W/2] "
                                     "(xyz and colour layout), not " + shapes);
  }
  if (config_.classes_path.empty ())
    config_.classes_path = defaultClassNamesPath ();
  class_names_ = readClassNames (config_.classes_path);
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
  static const char* layouts[] = {" (YOLOv5-seg layout)", " (YOLOv8-seg layout)", " (xyz layout)",
                                  " (xyz and colour layout)"};
  return "onnx:" + boost::filesystem::path (config_.model_path).filename ().string () + layouts[static_cast<int> (layout_)];
}

void
OnnxInstanceSegmenter::dropWiderThan (const RGBDFrame& frame, float max_extent, std::vector<Instance>& instances)
{
  if (!(max_extent > 0.f) || frame.depth.empty ())
    return;
  // The middle 90 % of a mask's pixels, over 0.9 (a filled mask's full width): a thread
  // leaking along a neighbour does not make it wide; its depth is the median's, so rim
  // pixels on the wall behind do not either.
  const auto span = [] (std::vector<float>& values) {
    const auto at = [&] (double q) {
      auto it = values.begin () + static_cast<std::ptrdiff_t> (q * static_cast<double> (values.size () - 1));
      std::nth_element (values.begin (), it, values.end ());
      return *it;
    };
    const float low = at (0.05);
    return (at (0.95) - low) / 0.9f;  // the width of a filled mask with that span
  };
  std::vector<float> us, vs, zs;
  const auto wide = [&] (const Instance& instance) {
    us.clear ();
    vs.clear ();
    zs.clear ();
    const cv::Rect box = instance.box & cv::Rect (0, 0, frame.depth.cols, frame.depth.rows);
    for (int v = box.y; v < box.y + box.height; ++v)
    {
      const std::uint8_t* m = instance.mask.ptr<std::uint8_t> (v);
      const float* z = frame.depth.ptr<float> (v);
      for (int u = box.x; u < box.x + box.width; ++u)
        if (m[u] && isValidDepth (z[u]))
        {
          us.push_back (static_cast<float> (u));
          vs.push_back (static_cast<float> (v));
          zs.push_back (z[u]);
        }
    }
    if (zs.empty ())
      return false;
    std::nth_element (zs.begin (), zs.begin () + static_cast<std::ptrdiff_t> (zs.size () / 2), zs.end ());
    const double z = zs[zs.size () / 2];
    return std::max (span (us) * z / frame.camera.fx, span (vs) * z / frame.camera.fy) > max_extent;
  };
  instances.erase (std::remove_if (instances.begin (), instances.end (), wide), instances.end ());
}

bool
OnnxInstanceSegmenter::segment (const RGBDFrame& frame, std::vector<Instance>& instances)
{
  using clock = std::chrono::steady_clock;
  const auto since = [] (clock::time_point t0) { return std::chrono::duration<double, std::milli> (clock::now () - t0).count (); };
  timings_ = SegmenterTimings ();
  auto t0 = clock::now ();
  if (layout_ == OnnxLayout::Xyz || layout_ == OnnxLayout::XyzRgb)
  {
    cv::Size content;
    net_.setInput (denseInput (frame, config_.dense_width, layout_, content));
    timings_.input_ms = since (t0);
    t0 = clock::now ();
    const cv::Mat output = net_.forward (output_names_.front ());
    timings_.forward_ms = since (t0);
    t0 = clock::now ();
    instances = decodeDense (output, cv::Size ((content.width + 1) / 2, (content.height + 1) / 2), frame.depth.size (), config_);
    dropWiderThan (frame, config_.max_object_extent, instances);
    timings_.decode_ms = since (t0);
    return true;
  }
  if (frame.color.empty () || frame.color.type () != CV_8UC3)
    throw Error ("OnnxInstanceSegmenter", "needs a CV_8UC3 colour image");
  Letterbox box;
  const cv::Mat input = letterbox (frame.color, config_.input_size, box);
  net_.setInput (cv::dnn::blobFromImage (input, 1.0 / 255.0, cv::Size (), cv::Scalar (), true, false));
  timings_.input_ms = since (t0);
  t0 = clock::now ();
  std::vector<cv::Mat> outputs;
  net_.forward (outputs, output_names_);
  timings_.forward_ms = since (t0);
  t0 = clock::now ();
  instances = decode (outputs, box, config_, class_names_);
  timings_.decode_ms = since (t0);
  return true;
}
}  // namespace recognition
}  // namespace cuefusion
