/// @file snapshot.cpp
/// @brief CPU snapshots of the views.
#include "render/snapshot.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <system_error>
#include <utility>

#include "io/colour_image.h"
#include "io/png_write.h"
#include "io/snapshot_files.h"

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
  return path(view_name(view), sequence);
}

std::string SnapshotWriter::path(const char* name, std::uint64_t sequence) const {
  char file[96];
  std::snprintf(file, sizeof file, "%s_%06llu.png", name,
                static_cast<unsigned long long>(sequence));
  return (std::filesystem::path(options_.dir) / file).string();
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
  if (options_.raycast_depth && !frame.depth_m.empty()) {
    const std::string file = path(kRaycastDepthView, frame.sequence);
    const Image<float>& d = frame.depth_m;
    depth_units_.resize(d.width(), d.height());
    for (std::size_t i = 0; i < d.size(); ++i) {
      const double units = std::round(d.data()[i] * kRaycastDepthUnitsPerMetre);
      depth_units_.data()[i] =
          units >= 1.0 ? static_cast<std::uint16_t>(std::min(units, 65535.0)) : 0;
    }
    try {
      write_png(file, d.width(), d.height(), PngFormat::kGrey16,
                [this](int y) -> const void* { return depth_units_.row(y); });
      ++files_written_;
    } catch (const std::exception& e) {
      return Status::internal(e.what());
    }
  }
  return Status::ok();
}

}  // namespace aoscan
