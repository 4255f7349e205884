/// @file ply_test.cpp
/// @brief Tests for src/io/ply.h: the contract's exact header and layout, round trips, determinism,
/// ASCII reading and rejected inputs.
#include "io/ply.h"

#include <cmath>
#include <cstring>
#include <filesystem>
#include <functional>

#include <gtest/gtest.h>

#include "core/status.h"
#include "support/error_message.h"
#include "support/scratch_dir.h"

namespace aoscan {
namespace {

using testing::error_message;
using testing::read_bytes;
using testing::ScratchDir;
using testing::write_text;

constexpr std::size_t kVertexBytes = 7 * 4 + 3;
constexpr std::size_t kFaceBytes = 1 + 3 * 4;

/// A unit square in z = 1 made of two triangles, with normals and AO.
TriangleMesh square() {
  TriangleMesh m;
  m.vertices = {{0, 0, 1}, {1, 0, 1}, {1, 1, 1}, {0, 1, 1.0f / 3.0f}};
  m.normals = {{0, 0, -1}, {0, 0, -1}, {0.6f, 0, -0.8f}, {0, 0, -1}};
  m.quality = {0.0f, 0.25f, 0.5f, 1.0f};
  m.faces = {{0, 1, 2}, {0, 2, 3}};
  return m;
}

float float_at(const std::string& bytes, std::size_t offset) {
  unsigned char b[4];
  std::memcpy(b, bytes.data() + offset, 4);
  const std::uint32_t bits = b[0] | (b[1] << 8) | (b[2] << 16) | (std::uint32_t{b[3]} << 24);
  float f;
  std::memcpy(&f, &bits, 4);
  return f;
}

TEST(Ply, HeaderAndLayoutAsTheContractSays) {
  ScratchDir dir;
  write_ply(dir.file("mesh.ply"), square());
  const std::string bytes = read_bytes(dir.file("mesh.ply"));
  const std::string header =
      "ply\n"
      "format binary_little_endian 1.0\n"
      "element vertex 4\n"
      "property float x\n"
      "property float y\n"
      "property float z\n"
      "property float nx\n"
      "property float ny\n"
      "property float nz\n"
      "property float quality\n"
      "property uchar red\n"
      "property uchar green\n"
      "property uchar blue\n"
      "element face 2\n"
      "property list uchar int vertex_indices\n"
      "end_header\n";
  ASSERT_EQ(bytes.size(), header.size() + 4 * kVertexBytes + 2 * kFaceBytes);
  EXPECT_EQ(bytes.substr(0, header.size()), header);
  EXPECT_EQ(ply_header(4, 2), header);
  // Vertex 2: position, normal, quality 0.5 and grey round(127.5) = 128.
  const std::size_t v2 = header.size() + 2 * kVertexBytes;
  EXPECT_EQ(float_at(bytes, v2 + 0), 1.0f);
  EXPECT_EQ(float_at(bytes, v2 + 12), 0.6f);
  EXPECT_EQ(float_at(bytes, v2 + 20), -0.8f);
  EXPECT_EQ(float_at(bytes, v2 + 24), 0.5f);
  EXPECT_EQ(bytes.substr(v2 + 28, 3), std::string(3, static_cast<char>(128)));
  // Grey of the other vertices: 0, round(63.75) = 64, 255.
  EXPECT_EQ(static_cast<unsigned char>(bytes[header.size() + 28]), 0);
  EXPECT_EQ(static_cast<unsigned char>(bytes[header.size() + kVertexBytes + 28]), 64);
  EXPECT_EQ(static_cast<unsigned char>(bytes[header.size() + 3 * kVertexBytes + 30]), 255);
  // Face 1: count 3, then 0 2 3 as little-endian int32.
  const std::size_t f1 = header.size() + 4 * kVertexBytes + kFaceBytes;
  EXPECT_EQ(bytes.substr(f1, kFaceBytes),
            std::string("\x03\x00\x00\x00\x00\x02\x00\x00\x00\x03\x00\x00\x00", kFaceBytes));
}

// points.ply: the mesh's vertex bytes exactly, after a header that has no face element.
TEST(Ply, PointsAreTheMeshVerticesWithoutAFaceElement) {
  ScratchDir dir;
  TriangleMesh m = square();
  m.colours = {{10, 20, 30}, {40, 50, 60}, {70, 80, 90}, {200, 100, 50}};
  write_ply(dir.file("mesh.ply"), m, MeshWriteOptions{true});
  write_points_ply(dir.file("points.ply"), m, MeshWriteOptions{true});
  const std::string mesh = read_bytes(dir.file("mesh.ply"));
  const std::string points = read_bytes(dir.file("points.ply"));
  const std::string header = ply_header(4, 0, false);
  EXPECT_EQ(header.find("element face"), std::string::npos);
  EXPECT_EQ(header, ply_header(4, 2).substr(0, ply_header(4, 2).find("element face")) + "end_header\n");
  ASSERT_EQ(points.size(), header.size() + 4 * kVertexBytes);
  EXPECT_EQ(points.substr(0, header.size()), header);
  EXPECT_EQ(points.substr(header.size()), mesh.substr(ply_header(4, 2).size(), 4 * kVertexBytes));
  const TriangleMesh back = read_ply(dir.file("points.ply"));
  EXPECT_EQ(back.vertices, m.vertices);
  EXPECT_EQ(back.normals, m.normals);
  EXPECT_EQ(back.quality, m.quality);
  EXPECT_TRUE(back.faces.empty());
  // A point cloud with faces is a usage error of the writer.
  EXPECT_THROW(PlyWriter(dir.file("bad.ply"), 4, 2, false), Error);
}

TEST(Ply, RoundTripIsExact) {
  ScratchDir dir;
  const TriangleMesh m = square();
  write_ply(dir.file("mesh.ply"), m);
  const TriangleMesh back = read_ply(dir.file("mesh.ply"));
  EXPECT_EQ(back.vertices, m.vertices);
  EXPECT_EQ(back.normals, m.normals);
  EXPECT_EQ(back.quality, m.quality);
  EXPECT_EQ(back.faces, m.faces);
}

TEST(Ply, IdenticalInputGivesIdenticalBytes) {
  ScratchDir dir;
  TriangleMesh m;
  for (int i = 0; i < 50000; ++i) {  // several write chunks
    m.vertices.emplace_back(i * 0.001f, std::sin(i * 0.01f), 2.0f);
    m.quality.push_back(static_cast<float>(i % 101) / 100.0f);
  }
  for (int i = 0; i + 2 < 50000; i += 3) m.faces.emplace_back(i, i + 1, i + 2);
  write_ply(dir.file("a.ply"), m);
  write_ply(dir.file("b.ply"), m);
  const std::string a = read_bytes(dir.file("a.ply"));
  EXPECT_EQ(a, read_bytes(dir.file("b.ply")));
  const TriangleMesh back = read_ply(dir.file("a.ply"));
  EXPECT_EQ(back.vertices, m.vertices);
  EXPECT_EQ(back.quality, m.quality);
  EXPECT_EQ(back.faces, m.faces);
  EXPECT_EQ(back.normals, std::vector<Eigen::Vector3f>(m.vertices.size(), Eigen::Vector3f::Zero()));
}

TEST(Ply, MissingNormalsAndQualityWriteZerosAndOne) {
  ScratchDir dir;
  TriangleMesh m = square();
  m.normals.clear();
  m.quality.clear();
  write_ply(dir.file("mesh.ply"), m);
  const TriangleMesh back = read_ply(dir.file("mesh.ply"));
  EXPECT_EQ(back.normals, std::vector<Eigen::Vector3f>(4, Eigen::Vector3f::Zero()));
  EXPECT_EQ(back.quality, std::vector<float>(4, 1.0f));
  const std::string bytes = read_bytes(dir.file("mesh.ply"));
  EXPECT_EQ(static_cast<unsigned char>(bytes[ply_header(4, 2).size() + 29]), 255);
}

TEST(Ply, EmptyMesh) {
  ScratchDir dir;
  write_ply(dir.file("mesh.ply"), TriangleMesh{});
  EXPECT_EQ(read_bytes(dir.file("mesh.ply")), ply_header(0, 0));
  EXPECT_TRUE(read_ply(dir.file("mesh.ply")).empty());
}

TEST(Ply, ReadsAsciiWithPolygonsAndExtraElements) {
  ScratchDir dir;
  write_text(dir.file("a.ply"),
             "ply\r\nformat ascii 1.0\r\ncomment made by hand\r\n"
             "element vertex 4\r\nproperty double x\r\nproperty double y\r\nproperty double z\r\n"
             "property uchar red\r\nproperty float quality\r\n"
             "element face 1\r\nproperty list uchar uint vertex_index\r\n"
             "element edge 1\r\nproperty int a\r\nproperty int b\r\n"
             "end_header\r\n"
             "0 0 0 255 0.5\r\n1 0 0 255 0.25\r\n1 1 0 1 1\r\n0 1 -2.5e-1 0 +0\r\n"
             "4 0 1 2 3\r\n0 1\r\n");
  const TriangleMesh m = read_ply(dir.file("a.ply"));
  ASSERT_EQ(m.vertices.size(), 4u);
  EXPECT_EQ(m.vertices[3], Eigen::Vector3f(0, 1, -0.25f));
  EXPECT_TRUE(m.normals.empty());
  EXPECT_EQ(m.quality, (std::vector<float>{0.5f, 0.25f, 1.0f, 0.0f}));
  EXPECT_EQ(m.faces, (std::vector<Eigen::Vector3i>{{0, 1, 2}, {0, 2, 3}}));
}

TEST(Ply, RejectsBadFiles) {
  ScratchDir dir;
  const std::string path = dir.file("bad.ply");
  auto expect_input_error = [&](const std::string& content, const std::string& part) {
    write_text(path, content);
    try {
      read_ply(path);
      ADD_FAILURE() << "no error for " << part;
    } catch (const Error& e) {
      EXPECT_EQ(e.code(), ExitCode::kBadInput);
      const std::string m = e.what();
      EXPECT_NE(m.find(path), std::string::npos) << m;
      EXPECT_NE(m.find(part), std::string::npos) << m;
    }
  };
  expect_input_error("solid cube\n", "not a PLY");
  expect_input_error("ply\nformat binary_big_endian 1.0\nelement vertex 0\nend_header\n",
                     "binary_big_endian");
  expect_input_error("ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\n", "end_header");
  expect_input_error("ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nend_header\n1\n",
                     "x, y or z");
  expect_input_error(
      "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
      "property float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n"
      "0 0 0\n1 0 0\n0 1 0\n3 0 1 3\n",
      "face 0");
  expect_input_error(
      "ply\nformat ascii 1.0\nelement vertex 2\nproperty float x\nproperty float y\n"
      "property float z\nend_header\n0 0 0\n1 zero 0\n",
      "vertex 1");
  expect_input_error(
      "ply\nformat binary_little_endian 1.0\nelement vertex 4000000000\nproperty float x\n"
      "property float y\nproperty float z\nend_header\n0123456789ab",
      "too short");
  // Found by fuzz/ply_fuzz: a second vertex element (here without quality) resized the
  // positions but not the first element's quality, and the mesh's arrays disagreed.
  expect_input_error(
      "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\n"
      "property float z\nproperty float quality\nelement vertex 2\nproperty float x\n"
      "property float y\nproperty float z\nend_header\n0 0 0 0.5\n0 0 0\n1 1 1\n",
      "bad.ply: PLY has more than one vertex element");

  // A valid binary file cut anywhere in its data is rejected, never read past its end.
  write_ply(path, square());
  const std::string full = read_bytes(path);
  for (std::size_t cut = ply_header(4, 2).size(); cut < full.size(); cut += 5)
    expect_input_error(full.substr(0, cut), "truncated");
  EXPECT_NE(error_message([&] { read_ply(dir.file("none.ply")); }).find("none.ply"),
            std::string::npos);
}

TEST(Ply, WriteRejectsInconsistentMeshAndUnwritablePath) {
  ScratchDir dir;
  TriangleMesh m = square();
  m.normals.pop_back();
  EXPECT_NE(error_message([&] { write_ply(dir.file("a.ply"), m); }).find("normals"),
            std::string::npos);
  m = square();
  m.faces.emplace_back(0, 1, 4);
  EXPECT_NE(error_message([&] { write_ply(dir.file("a.ply"), m); }).find("face 2"),
            std::string::npos);
  EXPECT_NE(error_message([&] {
              write_ply(dir.file("no/such/dir/a.ply"), square());
            }).find("no/such/dir/a.ply"),
            std::string::npos);
}

/// square() with a colour per vertex.
TriangleMesh coloured_square() {
  TriangleMesh m = square();
  m.colours = {{255, 0, 128}, {255, 0, 128}, {1, 2, 3}, {200, 100, 50}};
  return m;
}

/// The red, green, blue bytes of vertex `i` of a file of write_ply()'s layout with `faces` faces.
Rgb8 colour_at(const std::string& bytes, std::size_t vertices, std::size_t faces, std::size_t i) {
  const std::size_t at = ply_header(vertices, faces).size() + i * kVertexBytes + 28;
  return {static_cast<std::uint8_t>(bytes[at]), static_cast<std::uint8_t>(bytes[at + 1]),
          static_cast<std::uint8_t>(bytes[at + 2])};
}

TEST(PlyColour, ColoursAreWrittenAsRedGreenBlue) {
  ScratchDir dir;
  const TriangleMesh m = coloured_square();
  write_ply(dir.file("mesh.ply"), m);
  const std::string bytes = read_bytes(dir.file("mesh.ply"));
  ASSERT_EQ(bytes.size(), ply_header(4, 2).size() + 4 * kVertexBytes + 2 * kFaceBytes);
  for (std::size_t i = 0; i < 4; ++i) EXPECT_EQ(colour_at(bytes, 4, 2, i), m.colours[i]) << i;
  // Everything but the colour bytes is as without colours.
  TriangleMesh grey = m;
  grey.colours.clear();
  write_ply(dir.file("grey.ply"), grey);
  std::string without = read_bytes(dir.file("grey.ply"));
  for (std::size_t i = 0; i < 4; ++i)
    without.replace(ply_header(4, 2).size() + i * kVertexBytes + 28, 3,
                    bytes.substr(ply_header(4, 2).size() + i * kVertexBytes + 28, 3));
  EXPECT_EQ(bytes, without);
  const TriangleMesh back = read_ply(dir.file("mesh.ply"));
  EXPECT_EQ(back.vertices, m.vertices);
  EXPECT_EQ(back.quality, m.quality);
}

TEST(PlyColour, BakeAoMultipliesTheColourByTheAo) {
  ScratchDir dir;
  TriangleMesh m = coloured_square();  // quality 0, 0.25, 0.5, 1
  write_ply(dir.file("mesh.ply"), m, MeshWriteOptions{true});
  const std::string bytes = read_bytes(dir.file("mesh.ply"));
  EXPECT_EQ(colour_at(bytes, 4, 2, 0), (Rgb8{0, 0, 0}));
  EXPECT_EQ(colour_at(bytes, 4, 2, 1), (Rgb8{64, 0, 32}));  // 63.75, 0, 32
  EXPECT_EQ(colour_at(bytes, 4, 2, 2), (Rgb8{1, 1, 2}));    // 0.5, 1, 1.5: halves round up
  EXPECT_EQ(colour_at(bytes, 4, 2, 3), (Rgb8{200, 100, 50}));
  EXPECT_EQ(float_at(bytes, ply_header(4, 2).size() + kVertexBytes + 24), 0.25f);  // AO kept
  // The AO is clamped to [0, 1] (NaN as 0); without quality it is 1.
  m.quality = {1.5f, -0.5f, std::nanf(""), 0.5f};
  write_ply(dir.file("mesh.ply"), m, MeshWriteOptions{true});
  const std::string clamped = read_bytes(dir.file("mesh.ply"));
  EXPECT_EQ(colour_at(clamped, 4, 2, 0), (Rgb8{255, 0, 128}));
  EXPECT_EQ(colour_at(clamped, 4, 2, 1), (Rgb8{0, 0, 0}));
  EXPECT_EQ(colour_at(clamped, 4, 2, 2), (Rgb8{0, 0, 0}));
  EXPECT_EQ(colour_at(clamped, 4, 2, 3), (Rgb8{100, 50, 25}));
  m.quality.clear();
  write_ply(dir.file("a.ply"), m, MeshWriteOptions{true});
  write_ply(dir.file("b.ply"), m);
  EXPECT_EQ(read_bytes(dir.file("a.ply")), read_bytes(dir.file("b.ply")));
}

TEST(PlyColour, BakeAoWithoutColoursChangesNothing) {
  ScratchDir dir;
  write_ply(dir.file("a.ply"), square(), MeshWriteOptions{true});
  write_ply(dir.file("b.ply"), square());
  EXPECT_EQ(read_bytes(dir.file("a.ply")), read_bytes(dir.file("b.ply")));
}

TEST(PlyColour, WriterTakesAColourBesideTheGreyOfItsQuality) {
  ScratchDir dir;
  const TriangleMesh m = coloured_square();
  PlyWriter writer(dir.file("streamed.ply"), 4, 2);
  writer.vertex(m.vertices[0], m.normals[0], m.quality[0], m.colours[0]);
  writer.vertex(m.vertices[1], m.normals[1], m.quality[1], m.colours[1]);
  writer.vertex(m.vertices[2], m.normals[2], m.quality[2], m.colours[2]);
  writer.vertex(m.vertices[3], m.normals[3], m.quality[3]);  // grey 255
  for (const Eigen::Vector3i& f : m.faces) writer.face(f);
  writer.finish();
  TriangleMesh expected = m;
  expected.colours[3] = {255, 255, 255};
  write_ply(dir.file("whole.ply"), expected);
  EXPECT_EQ(read_bytes(dir.file("streamed.ply")), read_bytes(dir.file("whole.ply")));
}

TEST(PlyColour, ColourCountMustMatchTheVertices) {
  ScratchDir dir;
  TriangleMesh m = coloured_square();
  m.colours.pop_back();
  EXPECT_EQ(error_message([&] { write_ply(dir.file("a.ply"), m); }, ExitCode::kUsage),
            dir.file("a.ply") + ": mesh has 3 colours for 4 vertices");
  m.colours.resize(5);
  EXPECT_EQ(error_message([&] { write_ply(dir.file("a.ply"), m); }, ExitCode::kUsage),
            dir.file("a.ply") + ": mesh has 5 colours for 4 vertices");
  EXPECT_FALSE(std::filesystem::exists(dir.file("a.ply")));
}

}  // namespace
}  // namespace aoscan
