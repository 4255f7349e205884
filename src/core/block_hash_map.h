/// @file block_hash_map.h
/// @brief Open-addressing hash map from 64-bit keys to pool indices: the index of the sparse TSDF's
/// voxel blocks and of the MVAO grid's bricks.
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

namespace aoscan {

/// Open-addressing hash map from 64-bit keys (packed block coordinates, Morton codes of bricks)
/// to int indices into a pool: linear probing, power-of-two table, grown at half load. The
/// sparse structures keep their payload in pools that never move and only the small index in
/// here, so growing the table moves 12 bytes per entry. Reads are thread-safe; writes are
/// single-threaded.
class BlockHashMap {
 public:
  static constexpr std::uint64_t kEmpty = ~std::uint64_t{0};

  /// The index stored for `key`, or -1.
  int find(std::uint64_t key) const {
    if (keys_.empty()) return -1;
    std::size_t slot = hash(key) & mask_;
    while (true) {
      const std::uint64_t k = keys_[slot];
      if (k == key) return values_[slot];
      if (k == kEmpty) return -1;
      slot = (slot + 1) & mask_;
    }
  }
  /// Asks the CPU to fetch the table slot where find(key) starts, ahead of a batch of finds.
  void prefetch(std::uint64_t key) const {
    if (keys_.empty()) return;
    const std::size_t slot = hash(key) & mask_;
    __builtin_prefetch(&keys_[slot]);
    __builtin_prefetch(&values_[slot]);
  }
  /// Stores `value` for a key that is not present yet.
  void insert(std::uint64_t key, int value);
  void clear();
  std::size_t memory_bytes() const {
    return keys_.capacity() * sizeof(std::uint64_t) + values_.capacity() * sizeof(int);
  }

 private:
  static std::uint64_t hash(std::uint64_t x) {
    x ^= x >> 33;
    x *= 0xff51afd7ed558ccdULL;
    x ^= x >> 33;
    x *= 0xc4ceb9fe1a85ec53ULL;
    x ^= x >> 33;
    return x;
  }
  void grow();

  std::vector<std::uint64_t> keys_;
  std::vector<int> values_;
  std::size_t mask_ = 0;
  std::size_t size_ = 0;
};

}  // namespace aoscan
