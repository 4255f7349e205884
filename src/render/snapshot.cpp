/// @file snapshot.cpp
/// @brief CPU snapshots of the views.
#include "render/snapshot.h"

#include <cstdio>
#include <filesystem>
#include <system_error>
#include <utility>

#include "io/colour_image.h"

namespace aoscan {

SnapshotWriter::SnapshotWriter(SnapshotOptions options) : options_(std::move(options)) {
  if (options_.every_n == 0) throw usage_error("--snapshot-every must be at least 1");
  if (options_.dir.empty()) throw usage_error("--snapshot needs a folder");
  std::error_code ec;
  std::filesystem::create_directories(options_.dir, ec);
  if (ec || !std::filesystem::is_directory(options_.dir))
    throw usage_error(options_.dir + ": cannot create the snapshot folder" +
                      (ec ? ": " + ec.message() : std::string()));
}

std::string SnapshotWriter::path(View view, std::uint64_t sequence) const {
  char name[64];
  std::snprintf(name, sizeof name, "%s_%06llu.png", view_name(view),
                static_cast<unsigned long long>(sequence));
  return (std::filesystem::path(options_.dir) / name).string();
}

Status SnapshotWriter::offer(const ViewFrame& frame) {
  const bool due = offered_ % options_.every_n == 0;
  ++offered_;
  return due ? write(frame) : Status::ok();
}

Status SnapshotWriter::write(const ViewFrame& frame) {
  for (const View view : options_.views) {
    const std::string file = path(view, frame.sequence);
    try {
      composite_view(frame, view, buffer_, options_.style);
      if (buffer_.empty()) return Status::internal(file + ": frame has no image size");
      write_colour_png(file, buffer_);
      ++files_written_;
    } catch (const std::exception& e) {
      return Status::internal(e.what());
    }
  }
  return Status::ok();
}

}  // namespace aoscan
