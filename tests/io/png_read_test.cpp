// Tests for src/io/png_read.cpp beyond what tests/capture/png_depth_test.cpp covers through
// read_depth_png: inputs found by fuzz/png_fuzz.
#include "io/png_read.h"

#include <sys/resource.h>

#include <string>

#include <gtest/gtest.h>

#include "support/scratch_dir.h"

namespace aoscan {
namespace {

// Found by fuzz/png_fuzz: 69 bytes (a 2x2 grey PNG whose third chunk, zTXt, claims 1869573999
// bytes) made libpng allocate and clear 1.8 GB before it failed as truncated (50 s under ASan).
// Every chunk's length is now checked against the file before libpng sees it: the process's peak
// memory does not grow by the claimed size.
TEST(PngRead, ChunkLongerThanTheFileIsTruncatedWithoutAllocatingIt) {
  testing::ScratchDir dir;
  const std::string bytes(
      "\x89\x50\x4e\x47\x0d\x0a\x1a\x0a\x00\x00\x00\x0d\x49\x48\x44\x52\x00\x00\x00\x02\x00\x00"
      "\x00\x02\x08\x00\x00\x00\x00\x57\xdd\x52\xf8\x00\x00\x00\x0e\x73\x42\x49\x54\x78\xda\x63"
      "\x10\x50\xc4\x8b\x00\x00\x00\x6f\x6f\x6f\x6f\x6f\x6f\x6f\x6f\x6f\x6f\x6f\x6f\x7a\x54\x58"
      "\x74\x6f\x6f",
      69);
  const std::string path = dir.file("ztxt.png");
  testing::write_text(path, bytes);
  Image<std::uint16_t> out;
  rusage before{}, after{};
  getrusage(RUSAGE_SELF, &before);
  const Status s = read_grey16_png(path, out, 3);
  getrusage(RUSAGE_SELF, &after);
  EXPECT_EQ(s.code(), Status::Code::kCorruptFrame);
  EXPECT_EQ(s.message(), path + " (frame 3): truncated PNG");
  EXPECT_LT(after.ru_maxrss - before.ru_maxrss, 100 * 1024);  // KiB: far below the 1.8 GB claim
}

}  // namespace
}  // namespace aoscan
