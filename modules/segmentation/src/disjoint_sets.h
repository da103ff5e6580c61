// SPDX-License-Identifier: BSD-3-Clause
// Union–find over 0..n−1: what the colour division and the instance grouping (§4.2.1.3)
// share. Internal to the segmentation module (the map's label groups keep their own,
// LabelEquivalence, which resolves to the smaller label).
#pragma once

#include <cstddef>
#include <numeric>
#include <vector>

namespace cuefusion
{
namespace segmentation
{
namespace detail
{
/** \brief Disjoint sets with path halving. */
class DisjointSets
{
public:
  explicit DisjointSets (std::size_t n) : parent_ (n) { std::iota (parent_.begin (), parent_.end (), std::size_t{0}); }

  /** \brief The root of \a i's set. */
  std::size_t
  find (std::size_t i)
  {
    while (parent_[i] != i)
      i = parent_[i] = parent_[parent_[i]];
    return i;
  }

  /** \brief \a b's set joins \a a's: the union's root is \a a's root. */
  void
  join (std::size_t a, std::size_t b)
  {
    const std::size_t root = find (a);
    parent_[find (b)] = root;
  }

  /** \brief Every element's root. */
  std::vector<std::size_t>
  roots ()
  {
    for (std::size_t i = 0; i < parent_.size (); ++i)
      parent_[i] = find (i);
    return parent_;
  }

private:
  std::vector<std::size_t> parent_;
};
}  // namespace detail
}  // namespace segmentation
}  // namespace cuefusion
