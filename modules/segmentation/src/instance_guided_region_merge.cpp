#include <cuefusion/common/exceptions.h>
#include <cuefusion/segmentation/instance_guided_region_merge.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <utility>

namespace cuefusion
{
namespace segmentation
{
void
InstanceGuidedMergeConfig::validate () const
{
  if (!(std::isfinite (min_overlap) && min_overlap >= 0.f && min_overlap < 1.f))
    throw ParameterError ("--min-overlap", "must lie in [0, 1)");
}

InstanceGuidedRegionMerge::InstanceGuidedRegionMerge (const InstanceGuidedMergeConfig& config) { setConfig (config); }

void
InstanceGuidedRegionMerge::setConfig (const InstanceGuidedMergeConfig& config)
{
  config.validate ();
  config_ = config;
}

void
InstanceGuidedRegionMerge::merge (const cv::Mat& geometric, const std::vector<Instance>& instances, cv::Mat& fused,
                                  std::vector<SegmentInstance>* segments) const
{
  if (geometric.type () != CV_32S || geometric.empty ())
    throw Error ("InstanceGuidedRegionMerge", "L^G must be a non-empty CV_32S label image");
  for (const Instance& instance : instances)
    if (instance.mask.size () != geometric.size () || instance.mask.type () != CV_8U)
      throw Error ("InstanceGuidedRegionMerge", "instance mask is not CV_8U of L^G's size " +
                                                  std::to_string (geometric.cols) + "x" + std::to_string (geometric.rows));
  const cv::Mat ids = instancesToIdImage (instances, geometric.size ());  // id = index + 1, higher score on top

  // |l_g| and |l_g ∩ l_s|: per geometric segment a short list of (instance id, pixels).
  double max_label = 0.0;
  cv::minMaxLoc (geometric, nullptr, &max_label);
  const std::size_t labels = static_cast<std::size_t> (std::max (0.0, max_label)) + 1;
  std::vector<int> size (labels, 0);
  std::vector<std::vector<std::pair<int, int>>> overlap (labels);
  for (int y = 0; y < geometric.rows; ++y)
  {
    const std::int32_t* g = geometric.ptr<std::int32_t> (y);
    const std::uint16_t* s = ids.ptr<std::uint16_t> (y);
    for (int x = 0; x < geometric.cols; ++x)
    {
      if (g[x] <= 0)
        continue;
      ++size[static_cast<std::size_t> (g[x])];
      if (s[x] == 0)
        continue;
      auto& list = overlap[static_cast<std::size_t> (g[x])];
      auto it = std::find_if (list.begin (), list.end (), [&] (const std::pair<int, int>& e) { return e.first == s[x]; });
      if (it == list.end ())
        list.emplace_back (s[x], 1);
      else
        ++it->second;
    }
  }
  // Best instance per geometric segment (the lower id on a tie); joined when α > min.
  std::vector<int> joined (labels, 0);  // instance id, 0 = stays geometric
  for (std::size_t g = 1; g < labels; ++g)
  {
    int best = 0, best_count = 0;
    for (const auto& [id, count] : overlap[g])
      if (count > best_count || (count == best_count && id < best))
      {
        best = id;
        best_count = count;
      }
    if (best && static_cast<float> (best_count) > config_.min_overlap * static_cast<float> (size[g]))
      joined[g] = best;
  }

  // Output labels in raster order of first pixels; keys: instance id (joined) or −g.
  fused.create (geometric.size (), CV_32S);
  std::map<int, std::int32_t> output;
  if (segments)
    segments->assign (1, SegmentInstance ());
  for (int y = 0; y < geometric.rows; ++y)
  {
    const std::int32_t* g = geometric.ptr<std::int32_t> (y);
    std::int32_t* out = fused.ptr<std::int32_t> (y);
    for (int x = 0; x < geometric.cols; ++x)
    {
      if (g[x] <= 0)
      {
        out[x] = 0;
        continue;
      }
      const int instance = joined[static_cast<std::size_t> (g[x])];
      const int key = instance ? instance : -g[x];
      auto it = output.find (key);
      if (it == output.end ())
      {
        it = output.emplace (key, static_cast<std::int32_t> (output.size () + 1)).first;
        if (segments)
        {
          SegmentInstance info;
          if (instance)
          {
            const Instance& source = instances[static_cast<std::size_t> (instance - 1)];
            info.instance = instance - 1;
            info.class_id = source.class_id;
            info.class_name = source.class_name;
            info.score = source.score;
          }
          segments->push_back (info);
        }
      }
      out[x] = it->second;
    }
  }
  if (segments)
    for (std::size_t g = 1; g < labels; ++g)
      if (size[g] > 0)
      {
        const int key = joined[g] ? joined[g] : -static_cast<int> (g);
        ++(*segments)[static_cast<std::size_t> (output.at (key))].geometric_segments;
      }
}

void
masksAsSegments (const std::vector<Instance>& instances, const SurfacePlanes& planes, cv::Mat& labels,
                 std::vector<SegmentInstance>* segments)
{
  const cv::Size size (planes.width, planes.height);
  instancesToIdImage (instances, size).convertTo (labels, CV_32S);
  for (int y = 0; y < size.height; ++y)
    for (int x = 0; x < size.width; ++x)
      if (!std::isfinite (planes.z[static_cast<std::size_t> (y) * size.width + x]))
        labels.at<std::int32_t> (y, x) = 0;
  if (!segments)
    return;
  segments->assign (1, SegmentInstance ());
  for (std::size_t i = 0; i < instances.size (); ++i)
  {
    SegmentInstance info;
    info.instance = static_cast<int> (i);
    info.class_id = instances[i].class_id;
    info.class_name = instances[i].class_name;
    info.score = instances[i].score;
    segments->push_back (info);
  }
}
}  // namespace segmentation
}  // namespace cuefusion
