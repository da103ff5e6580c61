// SPDX-License-Identifier: BSD-3-Clause
#include <cuefusion/reconstruction/voxel_block_hash.h>

namespace cuefusion
{
namespace reconstruction
{
std::pair<std::int32_t, bool>
VoxelBlockHash::insert (std::uint64_t key, std::int32_t value)
{
  // Keep the load factor at most one half so probe runs stay short.
  if (2 * (size_ + 1) > keys_.size ())
    rehash (2 * keys_.size ());
  for (std::size_t slot = hash (key) & mask_;; slot = (slot + 1) & mask_)
  {
    if (keys_[slot] == key)
      return {values_[slot], false};
    if (keys_[slot] == kEmptyKey)
    {
      keys_[slot] = key;
      values_[slot] = value;
      ++size_;
      return {value, true};
    }
  }
}

void
VoxelBlockHash::clear (std::size_t capacity)
{
  std::size_t c = 16;
  while (c < capacity)
    c *= 2;
  keys_.assign (c, kEmptyKey);
  values_.assign (c, kNone);
  size_ = 0;
  mask_ = c - 1;
}

void
VoxelBlockHash::rehash (std::size_t capacity)
{
  std::vector<std::uint64_t> keys;
  std::vector<std::int32_t> values;
  keys.swap (keys_);
  values.swap (values_);
  clear (capacity);
  for (std::size_t i = 0; i < keys.size (); ++i)
    if (keys[i] != kEmptyKey)
      insert (keys[i], values[i]);
}
}  // namespace reconstruction
}  // namespace cuefusion
