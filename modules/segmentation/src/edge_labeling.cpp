#include <cuefusion/common/exceptions.h>
#include <cuefusion/segmentation/geometric_segmentation.h>

#include <opencv2/imgproc.hpp>

#include <cmath>
#include <vector>

namespace cuefusion
{
namespace segmentation
{
namespace
{
/** Gives valid, unlabelled pixels (edge pixels) to the labelled 4-neighbour they continue
  * in depth, breadth-first from all segments at once, up to \a radius steps out. Seeds are
  * queued in raster order, so the result is deterministic.
  */
void
assignEdgePixels (const cv::Mat& depth, const cv::Mat& valid, int radius, float max_jump, cv::Mat& labels)
{
  const int w = labels.cols, h = labels.rows;
  std::int32_t* label = labels.ptr<std::int32_t> ();
  const float* z = depth.ptr<float> ();
  const std::uint8_t* ok = valid.ptr<std::uint8_t> ();
  // Unassigned = valid and unlabelled. Seeds: labelled pixels next to one, in raster order.
  auto open = [&] (int i) { return ok[i] && label[i] == 0; };
  std::vector<int> queue, next;
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x)
    {
      const int i = y * w + x;
      if (label[i] > 0 && ((x > 0 && open (i - 1)) || (x + 1 < w && open (i + 1)) || (y > 0 && open (i - w)) ||
                           (y + 1 < h && open (i + w))))
        queue.push_back (i);
    }
  // One ring per round, so every pixel goes to the segment that reaches it first.
  for (int round = 0; round < radius && !queue.empty (); ++round)
  {
    next.clear ();
    for (const int i : queue)
    {
      const int x = i % w, y = i / w;
      const int neighbours[4] = {x + 1 < w ? i + 1 : -1, x > 0 ? i - 1 : -1, y + 1 < h ? i + w : -1, y > 0 ? i - w : -1};
      for (const int j : neighbours)
        if (j >= 0 && open (j) && std::abs (z[j] - z[i]) < max_jump * z[i])
        {
          label[j] = label[i];
          next.push_back (j);
        }
    }
    queue.swap (next);
  }
}
}  // namespace

int
labelEdgeMap (const cv::Mat& edges, const cv::Mat& depth, const EdgeLabelingConfig& config, cv::Mat& labels)
{
  config.validate ();
  if (edges.type () != CV_8U || depth.type () != CV_32F || edges.size () != depth.size () || edges.empty ())
    throw Error ("labelEdgeMap", "expects a CV_8U edge map and a CV_32F depth map of one size");
  cv::Mat valid (depth.size (), CV_8U);
  for (int y = 0; y < depth.rows; ++y)
  {
    const float* z = depth.ptr<float> (y);
    std::uint8_t* v = valid.ptr<std::uint8_t> (y);
    for (int x = 0; x < depth.cols; ++x)
      v[x] = (std::isfinite (z[x]) && z[x] > 0.f) ? 1 : 0;
  }

  // Boundary = edges ∪ invalid; closing it bridges gaps of up to 2·iterations pixels.
  cv::Mat boundary = (edges != 0) | (valid == 0);
  if (config.closing_iterations > 0)
    // Default border value: the image border neither grows nor erodes the boundary.
    cv::morphologyEx (boundary, boundary, cv::MORPH_CLOSE, cv::Mat (), cv::Point (-1, -1), config.closing_iterations);
  const cv::Mat interior = (boundary == 0) & (valid != 0);

  cv::Mat components, stats, centroids;
  const int n = cv::connectedComponentsWithStats (interior, components, stats, centroids, 4, CV_32S);
  // OpenCV numbers components in raster order of their first pixel; keep that order
  // and renumber the survivors 1..N.
  std::vector<std::int32_t> remap (static_cast<std::size_t> (n), 0);
  int count = 0;
  for (int c = 1; c < n; ++c)
    if (stats.at<std::int32_t> (c, cv::CC_STAT_AREA) >= config.min_segment_size)
      remap[static_cast<std::size_t> (c)] = ++count;
  labels.create (depth.size (), CV_32S);
  for (int y = 0; y < depth.rows; ++y)
  {
    const std::int32_t* in = components.ptr<std::int32_t> (y);
    std::int32_t* out = labels.ptr<std::int32_t> (y);
    for (int x = 0; x < depth.cols; ++x)
      out[x] = remap[static_cast<std::size_t> (in[x])];
  }
  if (config.edge_assignment_radius > 0)
    assignEdgePixels (depth.isContinuous () ? depth : depth.clone (), valid, config.edge_assignment_radius, config.max_depth_jump, labels);
  return count;
}
}  // namespace segmentation
}  // namespace cuefusion
