/// @file gltf.h
/// @brief mesh.glb: a mesh as glTF 2.0 binary (one file, the data in its BIN chunk), for viewers
/// and tools that read glTF (Blender, three.js, model-viewer, most web and AR viewers).
#pragma once

#include <string>

#include "core/mesh.h"
#include "io/mesh_write.h"

namespace aoscan {

/// Writes `mesh` as a glTF 2.0 binary file (`.glb`, written through write_atomically()): one
/// scene, one node `aoscan` holding one mesh of one triangle primitive (mode 4) with
/// - `POSITION`: float VEC3, the vertices as they are (metres, aoscan's world frame: the first
///   camera's frame, x right, y down, z forward), with the min and max glTF requires;
/// - `NORMAL` (only when the mesh has normals): float VEC3, unit length as glTF requires: a normal
///   whose squared length is within 1e-5 of 1 is written as it is, another one normalised, and a
///   zero or non-finite one replaced by the normalised sum of the area-weighted normals of the
///   vertex's faces, or by (0, 0, -1), towards the first camera, when that is zero too;
/// - `COLOR_0` (when the mesh has colours or quality): float VEC3, the PLY's red, green, blue
///   (written_colour(): the colour, multiplied by the AO with `options.bake_ao`, `--bake-ao`; the
///   AO as grey without colours) converted from sRGB bytes to the linear values glTF defines, so
///   that viewers show the colours mesh.ply shows;
/// - `_AO` (only when the mesh has quality): float SCALAR, the AO clamped to [0, 1] (NaN as 0);
///   glTF's leading underscore marks an application-specific attribute;
/// - indices: UNSIGNED_INT SCALAR, three per face, wound counter-clockwise seen from outside as
///   glTF's front faces are;
/// and one material `aoscan` (metallic 0, roughness 1, double-sided: a scanned surface is seen
/// from both sides) whose base colour COLOR_0 multiplies.
///
/// Coordinates: the vertex data keep aoscan's frame; the node carries a rotation of 180 degrees
/// about x (quaternion [1, 0, 0, 0]) that maps it to glTF's y-up frame, (x, y, z) -> (x, -y, -z),
/// so the model stands upright in viewers and a viewer's default camera (looking along -z) sees
/// it as the first camera did. A tool that wants aoscan's world coordinates reads POSITION and
/// ignores the node's rotation.
///
/// A mesh without faces (an empty mesh too) gives a valid glb whose scene holds the node without
/// a mesh (no buffer, no BIN chunk). Identical meshes give identical bytes. Throws usage_error for
/// an inconsistent mesh (check_mesh_for_writing(), and non-finite positions, which glTF does not
/// allow), Error (exit code 1) naming `path` when the file cannot be written or the mesh does not
/// fit a glb's 4 GiB.
void write_glb(const std::string& path, const TriangleMesh& mesh,
               const MeshWriteOptions& options = {});

/// The linear value glTF's COLOR_0 holds for an 8-bit sRGB channel `srgb` (IEC 61966-2-1:
/// c / 12.92 for c = srgb / 255 <= 0.04045, else ((c + 0.055) / 1.055)^2.4), computed in double
/// and rounded to float.
float srgb_to_linear(unsigned char srgb);

}  // namespace aoscan
