#pragma once
// Internal: the triangle list a per-topology cache (provoking vertices, silhouette edges) was built
// from, so that the cache is rebuilt only when a render's list differs from it.
#include "core/error.h"
#include "morph/mesh.h"

#include <cstring>
#include <string>
#include <vector>

namespace facesynth::render::detail {

class TriangleListKey {
public:
    // One memcmp over the list: vector's operator== calls memcmp once per triangle (~30 instructions each).
    [[nodiscard]] bool matches(const morph::Mesh& mesh) const {
        return vertices_ == mesh.num_vertices() && triangles_.size() == mesh.triangles.size() &&
               std::memcmp(triangles_.data(), mesh.triangles.data(), triangles_.size() * sizeof(morph::Triangle)) == 0;
    }
    // Records the mesh's list; throws core::Error on a vertex index out of range.
    void assign(const morph::Mesh& mesh) {
        const int v = mesh.num_vertices();
        for (const morph::Triangle& t : mesh.triangles)
            for (int i : t)
                if (i < 0 || i >= v) throw core::Error("render: triangle vertex index " + std::to_string(i) + " out of range");
        triangles_ = mesh.triangles;
        vertices_ = v;
    }
    [[nodiscard]] const std::vector<morph::Triangle>& triangles() const { return triangles_; }
    [[nodiscard]] int vertices() const { return vertices_; }

private:
    std::vector<morph::Triangle> triangles_;
    int vertices_ = 0;
};

}  // namespace facesynth::render::detail
