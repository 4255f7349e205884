/// @file atomic_write_test.cpp
/// @brief Atomic writes: the old file or the complete new one, never a partial file left behind.
#include "io/atomic_write.h"

#include <filesystem>
#include <fstream>
#include <stdexcept>
#include <string>

#include <gtest/gtest.h>

#include "core/status.h"
#include "support/scratch_dir.h"

namespace aoscan {
namespace {

namespace fs = std::filesystem;

std::string read_all(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), {});
}

void write_text(const std::string& path, const std::string& text) {
  std::ofstream out(path, std::ios::binary);
  out << text;
}

TEST(AtomicWrite, ReplacesTheFileWhenTheWriteSucceeds) {
  testing::ScratchDir scratch;
  const std::string path = scratch.file("out.txt");
  write_text(path, "old");
  write_atomically(path, [&](const std::string& partial) {
    EXPECT_EQ(partial, path + ".partial");
    EXPECT_EQ(read_all(path), "old");  // untouched while the new one is written
    write_text(partial, "new content");
  });
  EXPECT_EQ(read_all(path), "new content");
  EXPECT_FALSE(fs::exists(path + ".partial"));
}

TEST(AtomicWrite, AFailedWriteKeepsTheOldFileAndNamesTheFinalFile) {
  testing::ScratchDir scratch;
  const std::string path = scratch.file("mesh.ply");
  write_text(path, "the earlier mesh");
  try {
    write_atomically(path, [](const std::string& partial) {
      write_text(partial, "half a me");
      throw Error(ExitCode::kFailure, partial + ": cannot write: No space left on device");
    });
    FAIL() << "no error";
  } catch (const Error& e) {
    EXPECT_EQ(e.code(), ExitCode::kFailure);
    EXPECT_EQ(std::string(e.what()), path + ": cannot write: No space left on device");
  }
  EXPECT_EQ(read_all(path), "the earlier mesh");
  EXPECT_FALSE(fs::exists(path + ".partial"));
  // Any exception, not only aoscan's, removes the partial file.
  EXPECT_THROW(write_atomically(path,
                                [](const std::string& partial) {
                                  write_text(partial, "x");
                                  throw std::runtime_error("boom");
                                }),
               std::runtime_error);
  EXPECT_FALSE(fs::exists(path + ".partial"));
  EXPECT_EQ(read_all(path), "the earlier mesh");
}

TEST(AtomicWrite, WritableFolderIsCreatedOrRefusedWithAUsageError) {
  testing::ScratchDir scratch;
  const std::string dir = scratch.file("a/b/c");
  require_writable_folder(dir, "--out " + dir);
  EXPECT_TRUE(fs::is_directory(dir));
  EXPECT_TRUE(fs::is_empty(dir));  // the probe file is gone
  const std::string file = scratch.file("plain_file");
  write_text(file, "x");
  try {
    require_writable_folder(file + "/sub", "--out X");
    FAIL() << "no error";
  } catch (const Error& e) {
    EXPECT_EQ(e.code(), ExitCode::kUsage);
    EXPECT_EQ(std::string(e.what()).rfind("--out X: cannot create folder", 0), 0u) << e.what();
  }
  // /proc/1 exists but nobody, root included, can create a file in it.
  if (fs::is_directory("/proc/1")) {
    try {
      require_writable_folder("/proc/1", "--out /proc/1");
      FAIL() << "no error";
    } catch (const Error& e) {
      EXPECT_EQ(e.code(), ExitCode::kUsage);
      EXPECT_NE(std::string(e.what()).find("cannot write in this folder"), std::string::npos);
    }
  }
}

}  // namespace
}  // namespace aoscan
