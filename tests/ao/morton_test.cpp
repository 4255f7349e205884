/// @file morton_test.cpp
/// @brief Tests for src/ao/morton.h: fast codes equal the bit-by-bit reference, round trips, range
/// guard, ordering.
#include "ao/morton.h"

#include <cstdint>
#include <random>
#include <vector>

#include <gtest/gtest.h>

#include "support/ao_reference.h"

namespace aoscan {
namespace {

struct Cell {
  std::int32_t x, y, z;
};

/// Checks fast == reference for encode and decode, and that decode inverts encode.
void expect_consistent(const Cell& c) {
  const auto fast = morton_encode(c.x, c.y, c.z);
  const auto ref = morton_encode_reference(c.x, c.y, c.z);
  ASSERT_TRUE(fast.has_value()) << c.x << " " << c.y << " " << c.z;
  ASSERT_TRUE(ref.has_value());
  ASSERT_EQ(*fast, *ref) << c.x << " " << c.y << " " << c.z;
  ASSERT_EQ(*fast & ~kMortonCodeMask, 0u);
  Cell d{}, r{};
  morton_decode(*fast, d.x, d.y, d.z);
  morton_decode_reference(*fast, r.x, r.y, r.z);
  ASSERT_EQ(d.x, c.x);
  ASSERT_EQ(d.y, c.y);
  ASSERT_EQ(d.z, c.z);
  ASSERT_EQ(r.x, c.x);
  ASSERT_EQ(r.y, c.y);
  ASSERT_EQ(r.z, c.z);
}

TEST(Morton, RangeConstants) {
  EXPECT_EQ(kMortonMin, -(1 << 20));
  EXPECT_EQ(kMortonMax, (1 << 20) - 1);
  EXPECT_EQ(kMortonCodeMask, 0x7FFFFFFFFFFFFFFFull);
}

TEST(Morton, KnownCodes) {
  // The offset 2^20 sets bit 20 of each axis: code bits 60, 61, 62.
  EXPECT_EQ(*morton_encode(0, 0, 0), 0x7000000000000000ull);
  EXPECT_EQ(*morton_encode(kMortonMin, kMortonMin, kMortonMin), 0u);
  EXPECT_EQ(*morton_encode(kMortonMax, kMortonMax, kMortonMax), kMortonCodeMask);
  EXPECT_EQ(*morton_encode(kMortonMin + 1, kMortonMin, kMortonMin), 1u);
  EXPECT_EQ(*morton_encode(kMortonMin, kMortonMin + 1, kMortonMin), 2u);
  EXPECT_EQ(*morton_encode(kMortonMin, kMortonMin, kMortonMin + 1), 4u);
  EXPECT_EQ(*morton_encode(kMortonMin + 2, kMortonMin, kMortonMin), 8u);
  EXPECT_EQ(*morton_encode(kMortonMin + 3, kMortonMin + 3, kMortonMin + 3), 63u);
  static_assert(*morton_encode(kMortonMin, kMortonMin, kMortonMin + 1) == 4u);
}

TEST(Morton, EveryBitOfEveryAxisSeparately) {
  for (int axis = 0; axis < 3; ++axis) {
    for (int bit = 0; bit < kMortonBitsPerAxis; ++bit) {
      // Offset coordinate u = 2^bit on this axis, 0 (i.e. kMortonMin) on the others.
      const std::int32_t v = kMortonMin + (std::int32_t{1} << bit);
      Cell c{kMortonMin, kMortonMin, kMortonMin};
      (axis == 0 ? c.x : axis == 1 ? c.y : c.z) = v;
      const auto code = morton_encode(c.x, c.y, c.z);
      ASSERT_TRUE(code.has_value());
      EXPECT_EQ(*code, std::uint64_t{1} << (3 * bit + axis)) << "axis " << axis << " bit " << bit;
      expect_consistent(c);
      // The same bit cleared from an all-ones coordinate.
      const std::int32_t all_but = kMortonMax - (std::int32_t{1} << bit);
      Cell d{kMortonMax, kMortonMax, kMortonMax};
      (axis == 0 ? d.x : axis == 1 ? d.y : d.z) = all_but;
      EXPECT_EQ(*morton_encode(d.x, d.y, d.z),
                kMortonCodeMask & ~(std::uint64_t{1} << (3 * bit + axis)));
      expect_consistent(d);
    }
  }
}

TEST(Morton, EdgeValues) {
  std::vector<std::int32_t> values = {kMortonMin, kMortonMin + 1, kMortonMax, kMortonMax - 1, 0, -1,
                                      1};
  for (int k = 0; k < 20; ++k) {
    values.push_back(std::int32_t{1} << k);
    values.push_back(-(std::int32_t{1} << k));
    values.push_back((std::int32_t{1} << k) - 1);
    values.push_back(-(std::int32_t{1} << k) - 1);
  }
  values.push_back(-(std::int32_t{1} << 20));
  for (std::int32_t x : values)
    for (std::int32_t y : values)
      for (std::int32_t z : {values[0], values[2], values[4], values[5], x, y}) {
        expect_consistent({x, y, z});
        if (HasFatalFailure()) return;
      }
}

TEST(Morton, RandomRoundTripsMatchReference) {
  std::mt19937_64 rng(20240611);
  std::uniform_int_distribution<std::int32_t> coord(kMortonMin, kMortonMax);
  for (int i = 0; i < 1000000; ++i) {
    const Cell c{coord(rng), coord(rng), coord(rng)};
    const std::uint64_t code = *morton_encode(c.x, c.y, c.z);
    if (code != *morton_encode_reference(c.x, c.y, c.z)) FAIL() << "encode differs at " << i;
    Cell d{};
    morton_decode(code, d.x, d.y, d.z);
    if (d.x != c.x || d.y != c.y || d.z != c.z) FAIL() << "round trip differs at " << i;
  }
  // Random codes (bit 63 cleared) decode the same way in both and re-encode to themselves.
  for (int i = 0; i < 100000; ++i) {
    const std::uint64_t code = rng() & kMortonCodeMask;
    Cell d{}, r{};
    morton_decode(code, d.x, d.y, d.z);
    morton_decode_reference(code, r.x, r.y, r.z);
    if (d.x != r.x || d.y != r.y || d.z != r.z) FAIL() << "decode differs at " << i;
    if (*morton_encode(d.x, d.y, d.z) != code) FAIL() << "re-encode differs at " << i;
  }
}

TEST(Morton, OutOfRangeIsGuardedNotWrapped) {
  const std::int32_t bad[] = {kMortonMax + 1, kMortonMin - 1, INT32_MAX,
                              INT32_MIN,      1 << 21,        -(1 << 21) - 5};
  for (std::int32_t b : bad) {
    EXPECT_FALSE(morton_in_range(b, 0, 0)) << b;
    EXPECT_FALSE(morton_in_range(0, b, 0)) << b;
    EXPECT_FALSE(morton_in_range(0, 0, b)) << b;
    EXPECT_FALSE(morton_encode(b, 0, 0).has_value()) << b;
    EXPECT_FALSE(morton_encode(0, b, 0).has_value()) << b;
    EXPECT_FALSE(morton_encode(0, 0, b).has_value()) << b;
    EXPECT_FALSE(morton_encode_reference(b, 0, 0).has_value()) << b;
    EXPECT_FALSE(morton_encode_reference(0, 0, b).has_value()) << b;
  }
  EXPECT_TRUE(morton_in_range(kMortonMin, kMortonMax, 0));
}

TEST(Morton, DecodeIgnoresBit63) {
  const std::uint64_t code = *morton_encode(-5, 7, 123456);
  Cell d{};
  morton_decode(code | (std::uint64_t{1} << 63), d.x, d.y, d.z);
  EXPECT_EQ(d.x, -5);
  EXPECT_EQ(d.y, 7);
  EXPECT_EQ(d.z, 123456);
}

TEST(Morton, CodeGrowsAlongEachAxis) {
  std::mt19937 rng(7);
  std::uniform_int_distribution<std::int32_t> coord(kMortonMin, kMortonMax - 1);
  for (int i = 0; i < 10000; ++i) {
    const std::int32_t x = coord(rng), y = coord(rng), z = coord(rng);
    const std::uint64_t c = *morton_encode(x, y, z);
    ASSERT_LT(c, *morton_encode(x + 1, y, z));
    ASSERT_LT(c, *morton_encode(x, y + 1, z));
    ASSERT_LT(c, *morton_encode(x, y, z + 1));
  }
}

}  // namespace
}  // namespace aoscan
