/// @file vdb.cpp
/// @brief volume.vdb: bricks to OpenVDB leaves and back; the only file that includes OpenVDB.
#include "io/vdb.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <memory>
#include <optional>
#include <tuple>

#include <openvdb/io/File.h>
#include <openvdb/openvdb.h>

#include "core/log.h"
#include "core/status.h"
#include "io/atomic_write.h"

namespace aoscan {
namespace {

using FloatLeaf = openvdb::FloatTree::LeafNodeType;
using ColourLeaf = openvdb::Vec3STree::LeafNodeType;
static_assert(FloatLeaf::DIM == kBrickSize, "a brick must be exactly one OpenVDB leaf");

constexpr const char* kTsdfGrid = "tsdf";
constexpr const char* kWeightGrid = "weight";
constexpr const char* kColourGrid = "Cd";
constexpr const char* kColourWeightGrid = "colour_weight";
constexpr const char* kTruncationMeta = "truncation_m";

/// OpenVDB's file header: magic (8 bytes), file version, library major and minor (4 each), the
/// grid-offsets flag (1), then the UUID as 36 ASCII characters (file format 222 and later).
constexpr std::size_t kUuidOffset = 21;
constexpr std::size_t kUuidLength = 36;

/// Offset of local voxel (x, y, z) in an OpenVDB leaf's buffer (x-major).
int leaf_offset(int x, int y, int z) {
  return static_cast<int>(FloatLeaf::coordToOffset(openvdb::Coord(x, y, z)));
}

bool is_uuid_text(const char* s) {
  for (std::size_t i = 0; i < kUuidLength; ++i) {
    const bool dash = i == 8 || i == 13 || i == 18 || i == 23;
    if (dash ? s[i] != '-' : !std::isxdigit(static_cast<unsigned char>(s[i]))) return false;
  }
  return true;
}

/// Replaces the random UUID that OpenVDB writes into every file header by a UUID derived from the
/// rest of the file (two FNV-1a 64-bit hashes), so equal volumes give equal bytes. A header of an
/// unexpected layout is left alone with a warning.
void make_uuid_deterministic(const std::string& path) {
  std::fstream file(path, std::ios::in | std::ios::out | std::ios::binary);
  char header[kUuidOffset + kUuidLength];
  if (!file.read(header, sizeof(header)) || !is_uuid_text(header + kUuidOffset)) {
    spdlog::warn("{}: unexpected OpenVDB header layout; the file keeps its random UUID", path);
    return;
  }
  std::uint64_t h1 = 0xcbf29ce484222325ULL, h2 = 0x84222325cbf29ce4ULL;
  auto mix = [&](const char* data, std::size_t n) {
    for (std::size_t i = 0; i < n; ++i) {
      const auto byte = static_cast<unsigned char>(data[i]);
      h1 = (h1 ^ byte) * 0x100000001b3ULL;
      h2 = (h2 ^ (byte + 0x9eU)) * 0x100000001b3ULL;
    }
  };
  mix(header, kUuidOffset);
  std::vector<char> chunk(1 << 20);
  while (file.read(chunk.data(), static_cast<std::streamsize>(chunk.size())) || file.gcount() > 0)
    mix(chunk.data(), static_cast<std::size_t>(file.gcount()));
  char hex[33];
  std::snprintf(hex, sizeof(hex), "%016llx%016llx", static_cast<unsigned long long>(h1),
                static_cast<unsigned long long>(h2));
  hex[12] = '8';               // version nibble: custom (RFC 9562)
  hex[16] = "89ab"[h2 >> 62];  // variant: RFC 4122
  std::string uuid(hex, 8);
  uuid += '-' + std::string(hex + 8, 4) + '-' + std::string(hex + 12, 4) + '-' +
          std::string(hex + 16, 4) + '-' + std::string(hex + 20, 12);
  file.clear();
  file.seekp(static_cast<std::streamoff>(kUuidOffset));
  file.write(uuid.data(), static_cast<std::streamsize>(uuid.size()));
  if (!file.flush()) throw Error(ExitCode::kFailure, path + ": cannot write");
}

}  // namespace

VdbWriteStats write_volume_vdb(const std::string& path, const VolumeView& volume) {
  if (!(volume.voxel_size_m > 0.0) || !std::isfinite(volume.voxel_size_m) ||
      !(volume.truncation_m > 0.0) || !std::isfinite(volume.truncation_m))
    throw usage_error(path + ": voxel size and truncation must be positive and finite");
  openvdb::initialize();  // idempotent and thread-safe

  const auto truncation = static_cast<float>(volume.truncation_m);
  openvdb::FloatGrid::Ptr tsdf = openvdb::FloatGrid::create(truncation);
  openvdb::FloatGrid::Ptr weight = openvdb::FloatGrid::create(0.0f);
  const openvdb::math::Transform::Ptr transform =
      openvdb::math::Transform::createLinearTransform(volume.voxel_size_m);
  tsdf->setTransform(transform);
  weight->setTransform(transform);
  tsdf->setName(kTsdfGrid);
  weight->setName(kWeightGrid);
  tsdf->setGridClass(openvdb::GRID_LEVEL_SET);
  weight->setGridClass(openvdb::GRID_UNKNOWN);
  tsdf->insertMeta(kTruncationMeta, openvdb::FloatMetadata(truncation));
  openvdb::Vec3SGrid::Ptr colour = openvdb::Vec3SGrid::create(openvdb::Vec3s(0.0f));
  openvdb::FloatGrid::Ptr colour_weight = openvdb::FloatGrid::create(0.0f);
  colour->setTransform(transform);
  colour_weight->setTransform(transform);
  colour->setName(kColourGrid);
  colour_weight->setName(kColourWeightGrid);

  // Each brick becomes one leaf of each grid, built directly (no per-voxel tree descent).
  VdbWriteStats stats;
  VolumeBrick brick;
  for (std::size_t i = 0; i < volume.brick_count; ++i) {
    volume.brick(i, brick);
    const Eigen::Vector3i& o = brick.origin;
    if ((o.x() & (kBrickSize - 1)) || (o.y() & (kBrickSize - 1)) || (o.z() & (kBrickSize - 1)))
      throw usage_error(path + ": brick origin is not a multiple of 8");
    const openvdb::Coord origin(o.x(), o.y(), o.z());
    if (tsdf->tree().probeConstLeaf(origin) != nullptr)
      throw usage_error(path + ": two bricks share an origin");
    auto tsdf_leaf = std::make_unique<FloatLeaf>(origin, truncation, false);
    auto weight_leaf = std::make_unique<FloatLeaf>(origin, 0.0f, false);
    std::unique_ptr<ColourLeaf> colour_leaf;
    std::unique_ptr<FloatLeaf> colour_weight_leaf;
    std::size_t active = 0;
    for (int z = 0; z < kBrickSize; ++z) {
      for (int y = 0; y < kBrickSize; ++y) {
        for (int x = 0; x < kBrickSize; ++x) {
          const int src = x + kBrickSize * (y + kBrickSize * z);
          const float w = brick.weight[src], d = brick.sdf_m[src];
          if (!(w > 0.0f) || !std::isfinite(w) || !std::isfinite(d)) continue;
          const int dst = leaf_offset(x, y, z);
          tsdf_leaf->setValueOn(dst, d);
          weight_leaf->setValueOn(dst, w);
          ++active;
          if (!volume.has_colour || brick.colour_weight[src] == 0) continue;
          if (!colour_leaf) {
            colour_leaf = std::make_unique<ColourLeaf>(origin, openvdb::Vec3s(0.0f), false);
            colour_weight_leaf = std::make_unique<FloatLeaf>(origin, 0.0f, false);
          }
          const Rgb8& c = brick.colour[src];
          colour_leaf->setValueOn(dst, openvdb::Vec3s(c.r / 255.0f, c.g / 255.0f, c.b / 255.0f));
          colour_weight_leaf->setValueOn(dst, brick.colour_weight[src]);
        }
      }
    }
    if (active == 0) continue;
    tsdf->tree().addLeaf(tsdf_leaf.release());
    weight->tree().addLeaf(weight_leaf.release());
    if (colour_leaf) {
      colour->tree().addLeaf(colour_leaf.release());
      colour_weight->tree().addLeaf(colour_weight_leaf.release());
    }
    ++stats.bricks;
    stats.active_voxels += active;
  }

  openvdb::MetaMap file_meta;
  file_meta.insertMeta("creator", openvdb::StringMetadata("aoscan"));
  write_atomically(path, [&](const std::string& partial) {
    try {
      openvdb::io::File file(partial);
      openvdb::GridCPtrVec grids{tsdf, weight};
      if (colour->tree().leafCount() > 0) {
        grids.push_back(colour);
        grids.push_back(colour_weight);
      }
      file.write(grids, file_meta);
      file.close();
    } catch (const std::exception& e) {
      throw Error(ExitCode::kFailure, partial + ": cannot write: " + one_line(e.what()));
    }
    make_uuid_deterministic(partial);
  });
  std::error_code ec;
  stats.file_bytes = std::filesystem::file_size(path, ec);
  if (ec) throw Error(ExitCode::kFailure, path + ": cannot write: " + ec.message());
  return stats;
}

VolumeData read_volume_vdb(const std::string& path) {
  openvdb::initialize();
  openvdb::FloatGrid::Ptr tsdf, weight, colour_weight;
  openvdb::Vec3SGrid::Ptr colour;
  try {
    openvdb::io::File file(path);
    file.open(false);  // read everything now (no delayed loading of a file that may change)
    const auto float_grid = [&](const char* name) {
      openvdb::FloatGrid::Ptr grid = openvdb::gridPtrCast<openvdb::FloatGrid>(file.readGrid(name));
      if (!grid) throw input_error(path + ": grid '" + name + "' is not a float grid");
      return grid;
    };
    for (const char* name : {kTsdfGrid, kWeightGrid})
      if (!file.hasGrid(name)) throw input_error(path + ": no grid named '" + name + "'");
    tsdf = float_grid(kTsdfGrid);
    weight = float_grid(kWeightGrid);
    if (file.hasGrid(kColourGrid) != file.hasGrid(kColourWeightGrid))
      throw input_error(path + ": grid '" + (file.hasGrid(kColourGrid) ? kColourWeightGrid
                                                                       : kColourGrid) +
                        "' is missing beside '" +
                        (file.hasGrid(kColourGrid) ? kColourGrid : kColourWeightGrid) + "'");
    if (file.hasGrid(kColourGrid)) {
      colour = openvdb::gridPtrCast<openvdb::Vec3SGrid>(file.readGrid(kColourGrid));
      if (!colour) throw input_error(path + ": grid 'Cd' is not a Vec3s grid");
      colour_weight = float_grid(kColourWeightGrid);
    }
    file.close();
  } catch (const Error&) {
    throw;
  } catch (const std::exception& e) {
    throw input_error(path + ": cannot read OpenVDB file: " + one_line(e.what()));
  }
  const openvdb::math::Transform& xf = tsdf->transform();
  if (!(xf == weight->transform()))
    throw input_error(path + ": grids 'tsdf' and 'weight' have different transforms");
  const openvdb::math::UniformScaleMap::ConstPtr map =
      xf.constMap<openvdb::math::UniformScaleMap>();
  if (!map) throw input_error(path + ": transform is not a uniform scale without rotation");
  if (colour && (!(xf == colour->transform()) || !(xf == colour_weight->transform())))
    throw input_error(path + ": grids 'Cd' and 'colour_weight' have another transform than 'tsdf'");

  VolumeData out;
  out.voxel_size_m = xf.voxelSize()[0];
  const openvdb::FloatMetadata::ConstPtr meta =
      tsdf->getMetadata<openvdb::FloatMetadata>(kTruncationMeta);
  out.truncation_m = meta ? meta->value() : tsdf->background();
  const auto truncation = static_cast<float>(out.truncation_m);
  out.has_colour = colour != nullptr;

  tsdf->tree().voxelizeActiveTiles();
  openvdb::FloatGrid::ConstAccessor weights = weight->getConstAccessor();
  std::optional<openvdb::Vec3SGrid::ConstAccessor> colours;
  std::optional<openvdb::FloatGrid::ConstAccessor> colour_weights;
  if (colour) {
    colours.emplace(colour->getConstAccessor());
    colour_weights.emplace(colour_weight->getConstAccessor());
  }
  const auto byte = [](float v) {  // [0, 1] back to the byte it was written from
    return static_cast<std::uint8_t>(std::clamp(std::lrint(v * 255.0f), 0L, 255L));
  };
  for (auto leaf = tsdf->tree().cbeginLeaf(); leaf; ++leaf) {
    if (leaf->isEmpty()) continue;
    VolumeBrick brick;
    const openvdb::Coord o = leaf->origin();
    brick.origin = Eigen::Vector3i(o.x(), o.y(), o.z());
    brick.sdf_m.fill(truncation);
    brick.weight.fill(0.0f);
    for (auto v = leaf->cbeginValueOn(); v; ++v) {
      const openvdb::Coord local = v.getCoord() - o;
      const int i = local.x() + kBrickSize * (local.y() + kBrickSize * local.z());
      brick.sdf_m[i] = *v;
      brick.weight[i] = weights.getValue(v.getCoord());
      if (!colours || !colour_weights->isValueOn(v.getCoord())) continue;
      const float cw = colour_weights->getValue(v.getCoord());
      if (!(cw >= 1.0f)) continue;  // no colour (or not a count): the voxel stays uncoloured
      const openvdb::Vec3s c = colours->getValue(v.getCoord());
      if (!std::isfinite(c.x()) || !std::isfinite(c.y()) || !std::isfinite(c.z())) continue;
      brick.colour[i] = Rgb8{byte(c.x()), byte(c.y()), byte(c.z())};
      brick.colour_weight[i] = static_cast<std::uint8_t>(std::min(cw, 255.0f));
    }
    out.bricks.push_back(brick);
  }
  std::sort(out.bricks.begin(), out.bricks.end(), [](const VolumeBrick& a, const VolumeBrick& b) {
    return std::make_tuple(a.origin.z(), a.origin.y(), a.origin.x()) <
           std::make_tuple(b.origin.z(), b.origin.y(), b.origin.x());
  });
  return out;
}

}  // namespace aoscan
