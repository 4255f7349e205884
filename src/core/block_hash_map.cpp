/// @file block_hash_map.cpp
/// @brief BlockHashMap insertion and growth.
#include "core/block_hash_map.h"

namespace aoscan {

void BlockHashMap::insert(std::uint64_t key, int value) {
  if (keys_.empty() || 2 * (size_ + 1) > keys_.size()) grow();
  std::size_t slot = hash(key) & mask_;
  while (keys_[slot] != kEmpty) slot = (slot + 1) & mask_;
  keys_[slot] = key;
  values_[slot] = value;
  ++size_;
}

void BlockHashMap::clear() {
  keys_.clear();
  keys_.shrink_to_fit();
  values_.clear();
  values_.shrink_to_fit();
  mask_ = 0;
  size_ = 0;
}

void BlockHashMap::grow() {
  const std::size_t capacity = keys_.empty() ? 4096 : 2 * keys_.size();
  std::vector<std::uint64_t> old_keys(capacity, kEmpty);
  std::vector<int> old_values(capacity, -1);
  old_keys.swap(keys_);
  old_values.swap(values_);
  mask_ = capacity - 1;
  for (std::size_t i = 0; i < old_keys.size(); ++i) {
    if (old_keys[i] == kEmpty) continue;
    std::size_t slot = hash(old_keys[i]) & mask_;
    while (keys_[slot] != kEmpty) slot = (slot + 1) & mask_;
    keys_[slot] = old_keys[i];
    values_[slot] = old_values[i];
  }
}

}  // namespace aoscan
