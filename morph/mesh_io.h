#pragma once
// Mesh files: export to Wavefront OBJ and binary glTF 2.0 (.glb), import of OBJ and glTF
// (.gltf/.glb) triangle meshes for `model build`. Writes are atomic; every failure is a
// core::Error naming the file.
#include "morph/mesh.h"

#include <cstdint>
#include <filesystem>
#include <span>

namespace facesynth::morph {

// OBJ with `v x y z [r g b]` (per-vertex colour when the mesh has colours), `vt u v` (OBJ's v
// points up, so v_obj = 1 - v), `vn` normals, and `f a/a/a ...` faces (1-based).
void write_obj(const Mesh& mesh, const std::filesystem::path& path);

// glTF 2.0 binary: one mesh, one primitive with POSITION (with min/max), NORMAL, TEXCOORD_0 (when
// the mesh has uv), COLOR_0 (linear RGB, when it has colours) and uint32 indices. `png_texture`,
// when given, is an encoded PNG embedded as the base colour texture (sampled with TEXCOORD_0).
void write_glb(const Mesh& mesh, const std::filesystem::path& path, std::span<const std::uint8_t> png_texture = {});

// Whether `path` names a mesh format read_mesh understands (.obj, .gltf, .glb).
[[nodiscard]] bool is_mesh_file(const std::filesystem::path& path);

// Reads positions and triangles (polygons are fan-triangulated), plus per-vertex uv and colours
// when the file has them per vertex. glTF: the first primitive of the first mesh, indexed or not.
[[nodiscard]] Mesh read_mesh(const std::filesystem::path& path);

}  // namespace facesynth::morph
