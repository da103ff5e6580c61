// SPDX-License-Identifier: BSD-3-Clause
#include <cuefusion/segmentation/fragmentation.h>

#include <cuefusion/common/exceptions.h>

#include <algorithm>
#include <string>

namespace cuefusion
{
namespace segmentation
{
double
FragmentationReport::shareBelow (std::size_t bound) const
{
  const auto it = std::find (kBounds.begin (), kBounds.end (), bound);
  if (it == kBounds.end ())
    throw ParameterError ("FragmentationReport::shareBelow", "bound must be 100, 1000 or 10000 voxels, not " + std::to_string (bound));
  double share = 0.0;
  for (std::size_t k = 0; k <= static_cast<std::size_t> (it - kBounds.begin ()); ++k)
    share += share_by_size[k];
  return share;
}

FragmentationReport
fragmentationReport (const std::vector<SegmentRecord>& segments)
{
  FragmentationReport report;
  std::array<std::size_t, 4> voxels{};
  for (const SegmentRecord& s : segments)
  {
    if (s.voxels == 0)
      continue;
    const std::size_t size_class =
      static_cast<std::size_t> (std::upper_bound (FragmentationReport::kBounds.begin (), FragmentationReport::kBounds.end (), s.voxels) -
                                FragmentationReport::kBounds.begin ());
    ++report.segments;
    report.voxels += s.voxels;
    ++report.count_by_size[size_class];
    voxels[size_class] += s.voxels;
  }
  for (std::size_t k = 0; k < voxels.size (); ++k)
    report.share_by_size[k] = report.voxels > 0 ? static_cast<double> (voxels[k]) / static_cast<double> (report.voxels) : 0.0;
  return report;
}
}  // namespace segmentation
}  // namespace cuefusion
