/// @file mesh_compare.cpp
/// @brief aoscan-mesh-compare: mesh extraction from one volume.vdb by aoscan's marching cubes
/// (fusion/marching_cubes.h) and by OpenVDB's VolumeToMesh: milliseconds, vertex and triangle
/// counts, and both meshes as PLY for `aoscan-eval mesh`. OpenVDB's time counts what an exporter
/// built on it would do from the live TsdfVolume: grids, the observed-cell mask, meshing, normals.
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <functional>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include <openvdb/io/File.h>
#include <openvdb/openvdb.h>
#include <openvdb/tools/VolumeToMesh.h>
#include <tbb/global_control.h>
#include <CLI/CLI.hpp>

#include "core/status.h"
#include "fusion/tsdf/marching_cubes.h"
#include "io/ply.h"
#include "io/vdb.h"
#include "median_ms.h"
#include "pipeline/config.h"
#include "pipeline/volume_export.h"

namespace aoscan {
namespace {

/// The cells that aoscan's marching cubes meshes: voxel v when v and its 7 neighbours towards +x,
/// +y, +z are observed with weight >= min_weight (the mask VolumeToMesh gets for a like-for-like
/// comparison).
openvdb::BoolGrid::Ptr observed_cells(const openvdb::FloatGrid& weight, float min_weight) {
  openvdb::BoolGrid::Ptr mask = openvdb::BoolGrid::create(false);
  mask->setTransform(weight.transform().copy());
  auto cells = mask->getAccessor();
  auto w = weight.getConstAccessor();
  for (auto v = weight.cbeginValueOn(); v; ++v) {
    const openvdb::Coord c = v.getCoord();
    bool all = true;
    for (int i = 0; i < 8 && all; ++i) {
      const openvdb::Coord corner = c.offsetBy(i & 1, (i >> 1) & 1, i >> 2);
      all = w.isValueOn(corner) && w.getValue(corner) >= min_weight;
    }
    if (all) cells.setValueOn(c, true);
  }
  return mask;
}

/// The TSDF as OpenVDB grids in memory (what an OpenVDB exporter would have to build first): one
/// leaf per block, signed distance in metres and weight, observed voxels active.
std::pair<openvdb::FloatGrid::Ptr, openvdb::FloatGrid::Ptr> to_grids(const TsdfVolume& volume) {
  using Leaf = openvdb::FloatTree::LeafNodeType;
  const float truncation = volume.truncation_m();
  openvdb::FloatGrid::Ptr tsdf = openvdb::FloatGrid::create(truncation);
  openvdb::FloatGrid::Ptr weight = openvdb::FloatGrid::create(0.0f);
  const auto transform = openvdb::math::Transform::createLinearTransform(volume.voxel_size_m());
  tsdf->setTransform(transform);
  weight->setTransform(transform);
  for (const int index : volume.sorted_block_indices()) {
    const Eigen::Vector3i o = volume.block_coord(index) * kBlockSize;
    auto t = std::make_unique<Leaf>(openvdb::Coord(o.x(), o.y(), o.z()), truncation, false);
    auto w = std::make_unique<Leaf>(openvdb::Coord(o.x(), o.y(), o.z()), 0.0f, false);
    const VoxelBlock& block = volume.block(index);
    for (int z = 0; z < kBlockSize; ++z)
      for (int y = 0; y < kBlockSize; ++y)
        for (int x = 0; x < kBlockSize; ++x) {
          const Voxel& v = block.voxels[voxel_index(x, y, z)];
          if (v.count == 0) continue;
          const auto offset = Leaf::coordToOffset(openvdb::Coord(x, y, z));
          t->setValueOn(offset, v.tsdf() * truncation);
          w->setValueOn(offset, v.weight());
        }
    tsdf->tree().addLeaf(t.release());
    weight->tree().addLeaf(w.release());
  }
  return {tsdf, weight};
}

/// Unit vertex normals as the area-weighted sum of the adjacent faces' normals (VolumeToMesh gives
/// none; mesh.ply needs them).
void add_face_normals(TriangleMesh& mesh) {
  mesh.normals.assign(mesh.vertices.size(), Eigen::Vector3f::Zero());
  for (const Eigen::Vector3i& f : mesh.faces) {
    const Eigen::Vector3f n = (mesh.vertices[f[1]] - mesh.vertices[f[0]])
                                  .cross(mesh.vertices[f[2]] - mesh.vertices[f[0]]);
    for (int k = 0; k < 3; ++k) mesh.normals[f[k]] += n;
  }
  for (Eigen::Vector3f& n : mesh.normals) n.normalize();
}

/// VolumeToMesh's output as an indexed triangle mesh (each quad split along its 0-2 diagonal).
TriangleMesh to_triangle_mesh(const openvdb::tools::VolumeToMesh& mesher) {
  TriangleMesh mesh;
  for (std::size_t i = 0; i < mesher.pointListSize(); ++i) {
    const openvdb::Vec3s& p = mesher.pointList()[i];
    mesh.vertices.emplace_back(p.x(), p.y(), p.z());
  }
  for (std::size_t n = 0; n < mesher.polygonPoolListSize(); ++n) {
    const openvdb::tools::PolygonPool& pool = mesher.polygonPoolList()[n];
    for (std::size_t q = 0; q < pool.numQuads(); ++q) {
      const openvdb::Vec4I& quad = pool.quad(q);
      mesh.faces.emplace_back(quad[0], quad[1], quad[2]);
      mesh.faces.emplace_back(quad[0], quad[2], quad[3]);
    }
    for (std::size_t t = 0; t < pool.numTriangles(); ++t) {
      const openvdb::Vec3I& tri = pool.triangle(t);
      mesh.faces.emplace_back(tri[0], tri[1], tri[2]);
    }
  }
  return mesh;
}

int run(int argc, char** argv) {
  CLI::App app{
      "aoscan-mesh-compare: aoscan's marching cubes vs OpenVDB's VolumeToMesh on a volume.vdb "
      "(written by aoscan replay --save-volume)"};
  std::string volume_path, out_dir;
  float min_weight = static_cast<float>(FusionConfig{}.mesh_min_weight);
  int repeat = 5;
  int threads = 0;
  app.add_option("VOLUME", volume_path, "volume.vdb")->required()->check(CLI::ExistingFile);
  app.add_option("--out", out_dir, "write ours.ply and openvdb.ply here (for aoscan-eval mesh)");
  app.add_option("--min-weight", min_weight, "cells need 8 corners of at least this TSDF weight")
      ->capture_default_str();
  app.add_option("--repeat", repeat, "runs per method; the median time is printed")
      ->capture_default_str()
      ->check(CLI::PositiveNumber);
  app.add_option("--threads", threads, "TBB threads (default: all cores)");
  CLI11_PARSE(app, argc, argv);

  try {
    std::unique_ptr<tbb::global_control> budget;
    if (threads > 0)
      budget = std::make_unique<tbb::global_control>(tbb::global_control::max_allowed_parallelism,
                                                     static_cast<std::size_t>(threads));

    // aoscan: the bricks back into a TsdfVolume, then extract_mesh().
    const VolumeData data = read_volume_vdb(volume_path);
    FusionConfig fusion;
    fusion.voxel_size_m = data.voxel_size_m;
    fusion.truncation_m = data.truncation_m;
    fusion.max_blocks = std::max<int>(fusion.max_blocks, static_cast<int>(data.bricks.size()));
    TsdfVolume volume(fusion);
    load_volume(data, volume);
    // OpenVDB: the grids as read from the file, the same cells through a surface mask.
    openvdb::initialize();
    openvdb::io::File file(volume_path);
    file.open(false);
    const auto tsdf = openvdb::gridPtrCast<openvdb::FloatGrid>(file.readGrid("tsdf"));
    const auto weight = openvdb::gridPtrCast<openvdb::FloatGrid>(file.readGrid("weight"));
    file.close();

    TriangleMesh ours, vdb, vdb_unmasked;
    std::pair<openvdb::FloatGrid::Ptr, openvdb::FloatGrid::Ptr> in_memory;
    openvdb::BoolGrid::Ptr mask;
    const std::vector<double> ms = median_ms(
        repeat,
        {[&] { ours = extract_mesh(volume, min_weight); }, [&] { in_memory = to_grids(volume); },
         [&] { mask = observed_cells(*weight, min_weight); },
         [&] {
           openvdb::tools::VolumeToMesh mesher(/*isovalue=*/0.0, /*adaptivity=*/0.0);
           mesher.setSurfaceMask(mask);
           mesher(*tsdf);
           vdb = to_triangle_mesh(mesher);
         },
         [&] { add_face_normals(vdb); },
         [&] {
           openvdb::tools::VolumeToMesh mesher(0.0, 0.0);
           mesher(*tsdf);
           vdb_unmasked = to_triangle_mesh(mesher);
         }});
    const double ours_ms = ms[0], grids_ms = ms[1], mask_ms = ms[2], vdb_ms = ms[3],
                 normals_ms = ms[4], vdb_unmasked_ms = ms[5];
    if (in_memory.first->activeVoxelCount() != tsdf->activeVoxelCount())
      throw Error(ExitCode::kFailure, "in-memory grids differ from " + volume_path);

    std::printf("volume       %s: %zu bricks, %lld observed voxels, voxel %.4f m\n",
                volume_path.c_str(), data.bricks.size(),
                static_cast<long long>(tsdf->activeVoxelCount()), data.voxel_size_m);
    std::printf("threads      %d (TBB), median of %d rounds\n",
                static_cast<int>(tbb::global_control::active_value(
                    tbb::global_control::max_allowed_parallelism)),
                repeat);
    std::printf("%-34s %10s %10s %10s\n", "method", "ms", "vertices", "triangles");
    std::printf("%-34s %10.1f %10zu %10zu\n", "aoscan extract_mesh", ours_ms, ours.vertices.size(),
                ours.faces.size());
    std::printf("%-34s %10.1f %10zu %10zu\n", "openvdb VolumeToMesh, masked, total",
                grids_ms + mask_ms + vdb_ms + normals_ms, vdb.vertices.size(), vdb.faces.size());
    std::printf("%-34s %10.1f\n", "  TsdfVolume -> OpenVDB grids", grids_ms);
    std::printf("%-34s %10.1f\n", "  weight mask (8 corners observed)", mask_ms);
    std::printf("%-34s %10.1f\n", "  VolumeToMesh + to triangles", vdb_ms);
    std::printf("%-34s %10.1f\n", "  vertex normals from faces", normals_ms);
    std::printf("%-34s %10.1f %10zu %10zu\n", "openvdb VolumeToMesh, no mask", vdb_unmasked_ms,
                vdb_unmasked.vertices.size(), vdb_unmasked.faces.size());
    if (!out_dir.empty()) {
      std::filesystem::create_directories(out_dir);
      write_ply((std::filesystem::path(out_dir) / "ours.ply").string(), ours);
      write_ply((std::filesystem::path(out_dir) / "openvdb.ply").string(), vdb);
      write_ply((std::filesystem::path(out_dir) / "openvdb_unmasked.ply").string(), vdb_unmasked);
    }
  } catch (const Error& e) {
    std::fprintf(stderr, "aoscan-mesh-compare: error: %s\n", e.what());
    return static_cast<int>(e.code());
  } catch (const std::exception& e) {
    std::fprintf(stderr, "aoscan-mesh-compare: error: %s\n", e.what());
    return 1;
  }
  return 0;
}

}  // namespace
}  // namespace aoscan

int main(int argc, char** argv) {
  return aoscan::run(argc, argv);
}
