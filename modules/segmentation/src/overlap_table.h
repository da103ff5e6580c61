// SPDX-License-Identifier: BSD-3-Clause
#pragma once

#include <algorithm>
#include <cstddef>
#include <utility>
#include <vector>

namespace cuefusion
{
namespace segmentation
{
/** \brief Per label l of one label image: its pixel count #l and the labels of another
  * image it meets, each with its pixels, in the order first met. A segment meets a
  * handful of masks or model labels, so a short list beats a map. The one table behind
  * InstanceGuidedRegionMerge (segments × instances) and SegmentPropagation (frame
  * segments × model labels, Π of §4.2.2.3).
  */
template <typename Label>
struct OverlapTable
{
  using Entry = std::pair<Label, int>;
  std::vector<int> size;                    ///< #l (filled by the caller)
  std::vector<std::vector<Entry>> overlap;  ///< by label l: (other label, pixels)

  explicit OverlapTable (std::size_t labels = 0) : size (labels, 0), overlap (labels) {}

  std::size_t labels () const { return size.size (); }

  /** \brief \a count more pixels where \a l meets \a other; returns the entry's index in
    * l's list. */
  std::size_t
  add (std::size_t l, Label other, int count)
  {
    auto& list = overlap[l];
    const auto it = std::find_if (list.begin (), list.end (), [other] (const Entry& e) { return e.first == other; });
    if (it != list.end ())
    {
      it->second += count;
      return static_cast<std::size_t> (it - list.begin ());
    }
    list.emplace_back (other, count);
    return list.size () - 1;
  }

  /** \brief Adds \a more (same labels: counted over other pixels), its entries in order. */
  void
  add (const OverlapTable& more)
  {
    for (std::size_t l = 0; l < size.size (); ++l)
    {
      size[l] += more.size[l];
      for (const auto& [other, count] : more.overlap[l])
        add (l, other, count);
    }
  }

  /** \brief The other label meeting \a l on most pixels (the lower label on a tie) and
    * its pixels; (0, 0) when none. */
  Entry
  best (std::size_t l) const
  {
    Entry out (Label (0), 0);
    for (const auto& [other, count] : overlap[l])
      if (count > out.second || (count == out.second && other < out.first))
        out = Entry (other, count);
    return out;
  }
};
}  // namespace segmentation
}  // namespace cuefusion
