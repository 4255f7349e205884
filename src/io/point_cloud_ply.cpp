/// @file point_cloud_ply.cpp
/// @brief Streaming binary little-endian PLY point clouds.
#include "io/point_cloud_ply.h"

#include <cstring>

#include "core/checked_close.h"
#include "core/status.h"

namespace aoscan {
namespace {

constexpr std::size_t kBufferBytes = 1 << 20;

void put_f32(std::vector<unsigned char>& out, float f) {
  std::uint32_t bits = 0;
  std::memcpy(&bits, &f, sizeof bits);
  for (int shift = 0; shift < 32; shift += 8)
    out.push_back(static_cast<unsigned char>(bits >> shift));
}

}  // namespace

std::string point_cloud_ply_header(std::int64_t count, bool normals) {
  std::string h = "ply\nformat binary_little_endian 1.0\nelement vertex " + std::to_string(count) +
                  "\nproperty float x\nproperty float y\nproperty float z\n";
  if (normals) h += "property float nx\nproperty float ny\nproperty float nz\n";
  return h + "end_header\n";
}

PointCloudPlyWriter::PointCloudPlyWriter(const std::string& path, std::int64_t count, bool normals)
    : path_(path), count_(count), normals_(normals) {
  if (count < 0) throw usage_error(path + ": a point cloud cannot have a negative point count");
  file_ = std::fopen(path.c_str(), "wb");
  if (!file_) throw_write_failed(path_);
  const std::string header = point_cloud_ply_header(count, normals);
  if (std::fwrite(header.data(), 1, header.size(), file_) != header.size())
    throw_write_failed(path_);
  buffer_.reserve(kBufferBytes + 64);
}

PointCloudPlyWriter::~PointCloudPlyWriter() {
  if (file_) std::fclose(file_);
}

void PointCloudPlyWriter::add(const Eigen::Vector3f& p, const Eigen::Vector3f& n) {
  if (!file_) throw Error(ExitCode::kFailure, path_ + ": point cloud already closed");
  if (added_ == count_)
    throw Error(ExitCode::kFailure, path_ + ": more points than the " + std::to_string(count_) +
                                        " the header announces");
  for (int k = 0; k < 3; ++k) put_f32(buffer_, p[k]);
  if (normals_)
    for (int k = 0; k < 3; ++k) put_f32(buffer_, n[k]);
  ++added_;
  if (buffer_.size() >= kBufferBytes) flush();
}

void PointCloudPlyWriter::flush() {
  if (!buffer_.empty() && std::fwrite(buffer_.data(), 1, buffer_.size(), file_) != buffer_.size())
    throw_write_failed(path_);
  buffer_.clear();
}

void PointCloudPlyWriter::close() {
  if (!file_) return;
  flush();
  close_checked(file_, path_);
  if (added_ != count_)
    throw Error(ExitCode::kFailure, path_ + ": " + std::to_string(added_) + " points written, " +
                                        std::to_string(count_) + " announced");
}

}  // namespace aoscan
