/// @file atomic_write.cpp
/// @brief Partial file, fsync, rename.
#include "io/atomic_write.h"

#include <fcntl.h>
#include <stdlib.h>
#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <filesystem>

#include "core/status.h"

namespace aoscan {
namespace {

/// Flushes `path`'s data (a file) or its entries (a folder) to the disk; false with errno set
/// when that fails. Folders that cannot be opened or synced (some file systems) are not an error:
/// the rename is atomic without it, only not yet durable.
bool sync_path(const std::string& path, bool folder) {
  const int fd = ::open(path.c_str(), (folder ? O_RDONLY | O_DIRECTORY : O_WRONLY) | O_CLOEXEC);
  if (fd < 0) return folder;
  const bool ok = ::fsync(fd) == 0 || folder;
  const int saved = errno;
  ::close(fd);
  errno = saved;
  return ok;
}

/// `message` with every occurrence of `from` replaced by `to`.
std::string replaced(std::string message, const std::string& from, const std::string& to) {
  for (auto at = message.find(from); at != std::string::npos; at = message.find(from, at + to.size()))
    message.replace(at, from.size(), to);
  return message;
}

}  // namespace

void write_atomically(const std::string& path,
                      const std::function<void(const std::string& partial_path)>& write) {
  const std::string partial = path + kPartialSuffix;
  std::error_code ignored;
  try {
    write(partial);
    if (!sync_path(partial, false)) throw_write_failed(partial);
    if (std::rename(partial.c_str(), path.c_str()) != 0) throw_write_failed(path);
  } catch (const Error& e) {
    std::filesystem::remove(partial, ignored);
    throw Error(e.code(), replaced(e.what(), partial, path));
  } catch (...) {
    std::filesystem::remove(partial, ignored);
    throw;
  }
  const std::filesystem::path parent = std::filesystem::path(path).parent_path();
  sync_path(parent.empty() ? "." : parent.string(), true);
}

void require_writable_folder(const std::string& dir, const std::string& label) {
  std::error_code ec;
  std::filesystem::create_directories(dir, ec);
  if (ec || !std::filesystem::is_directory(dir))
    throw usage_error(label + ": cannot create folder: " +
                      (ec ? ec.message() : std::string("a file of that name exists")));
  std::string probe = (std::filesystem::path(dir) / ".aoscan-write-test-XXXXXX").string();
  const int fd = ::mkstemp(probe.data());
  if (fd < 0) throw usage_error(label + ": cannot write in this folder: " + std::strerror(errno));
  ::close(fd);
  std::filesystem::remove(probe, ec);
}

}  // namespace aoscan
