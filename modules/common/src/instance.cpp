// SPDX-License-Identifier: BSD-3-Clause
#include <cuefusion/common/exceptions.h>
#include <cuefusion/common/instance.h>

#include <map>
#include <numeric>

namespace cuefusion
{
cv::Mat
instancesToIdImage (const std::vector<Instance>& instances, cv::Size size)
{
  if (instances.size () > 65535)
    throw Error ("instancesToIdImage", "more than 65535 instances");
  cv::Mat ids (size, CV_16U, cv::Scalar (0));
  // Paint in increasing score, so the higher score ends on top (stable: earlier wins ties).
  std::vector<std::size_t> order (instances.size ());
  std::iota (order.begin (), order.end (), 0);
  std::stable_sort (order.begin (), order.end (),
                    [&] (std::size_t a, std::size_t b) { return instances[a].score > instances[b].score; });
  for (auto it = order.rbegin (); it != order.rend (); ++it)
  {
    const Instance& instance = instances[*it];
    if (instance.mask.size () != size || instance.mask.type () != CV_8U)
      throw Error ("instancesToIdImage", "instance mask is not CV_8U of the image's size");
    ids.setTo (cv::Scalar (static_cast<double> (*it + 1)), instance.mask);
  }
  return ids;
}

std::vector<Instance>
instancesFromIdImage (const cv::Mat& ids, std::vector<int>* ids_out)
{
  if (ids.type () != CV_16U && ids.type () != CV_32S)
    throw Error ("instancesFromIdImage", "expects a CV_16U or CV_32S id image");
  cv::Mat ids32;
  ids.convertTo (ids32, CV_32S);
  std::map<int, cv::Rect> boxes;
  for (int y = 0; y < ids32.rows; ++y)
    for (int x = 0; x < ids32.cols; ++x)
    {
      const int id = ids32.at<std::int32_t> (y, x);
      if (id <= 0)
        continue;
      auto it = boxes.find (id);
      if (it == boxes.end ())
        boxes.emplace (id, cv::Rect (x, y, 1, 1));
      else
        it->second |= cv::Rect (x, y, 1, 1);
    }
  // Every instance carries a full-frame mask: the count is bounded so that a PNG of
  // 65,535 ids cannot take gigabytes; each mask is filled inside its box only.
  constexpr std::size_t max_instances = 1024;
  if (boxes.size () > max_instances)
    throw Error ("instance id image", "holds " + std::to_string (boxes.size ()) + " distinct instance ids (at most " +
                                        std::to_string (max_instances) + ")");
  std::vector<Instance> instances;
  if (ids_out)
    ids_out->clear ();
  for (const auto& [id, box] : boxes)
  {
    Instance instance;
    instance.mask = cv::Mat::zeros (ids32.size (), CV_8U);
    instance.mask (box).setTo (1, ids32 (box) == id);
    instance.box = box;
    instances.push_back (std::move (instance));
    if (ids_out)
      ids_out->push_back (id);
  }
  return instances;
}
}  // namespace cuefusion
