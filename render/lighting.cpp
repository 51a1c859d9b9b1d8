#include "render/lighting.h"

#include "core/error.h"

#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>

namespace facesynth::render {

Lighting uniform_lighting(float radiance) {
    Lighting lighting;
    lighting.sh = {};
    lighting.sh[0] = {radiance * kShUniformDc, radiance * kShUniformDc, radiance * kShUniformDc};
    return lighting;
}

std::array<float, 3> diffuse_shading(const Lighting& lighting, const std::array<float, 3>& view_normal) {
    const auto [x, y, z] = view_normal;
    // The real SH basis in lighting.sh's order, as the renderer's shader evaluates it.
    const std::array<float, 9> basis{0.282095f, 0.488603f * y, 0.488603f * z, 0.488603f * x, 1.092548f * x * y,
                                     1.092548f * y * z, 0.315392f * (3 * z * z - 1), 1.092548f * x * z, 0.546274f * (x * x - y * y)};
    std::array<float, 3> shading{};
    for (std::size_t c = 0; c < 3; ++c) {
        float sh = 0;
        for (std::size_t k = 0; k < basis.size(); ++k) sh += lighting.sh[k][c] * kShBandScale[k] * basis[k];
        shading[c] = lighting.ambient[c] + std::max(sh, 0.0f);
    }
    for (const DirectionalLight& light : lighting.lights) {
        const auto [lx, ly, lz] = light.direction;
        const float length = std::sqrt(lx * lx + ly * ly + lz * lz);
        const float n_dot_l = length > 0 ? (x * lx + y * ly + z * lz) / length : 0.0f;
        for (std::size_t c = 0; c < 3; ++c) shading[c] += light.colour[c] * std::max(n_dot_l, 0.0f);
    }
    return shading;
}

void to_json(nlohmann::json& j, const DirectionalLight& light) {
    j = nlohmann::json{{"direction", light.direction}, {"colour", light.colour}};
}

namespace {

template <typename T>
void read_key(const nlohmann::json& j, const char* key, T& value) {
    if (!j.contains(key)) return;
    try {
        j.at(key).get_to(value);
    } catch (const nlohmann::json::exception& e) {
        throw core::Error(std::string("lighting: key '") + key + "': " + e.what());
    }
}

}  // namespace

void from_json(const nlohmann::json& j, DirectionalLight& light) {
    read_key(j, "direction", light.direction);
    read_key(j, "colour", light.colour);
}

void to_json(nlohmann::json& j, const Lighting& lighting) {
    j = nlohmann::json{{"sh", lighting.sh},           {"ambient", lighting.ambient}, {"lights", lighting.lights},
                       {"specular", lighting.specular}, {"shininess", lighting.shininess}, {"gamma", lighting.gamma},
                       {"shadows", lighting.shadows}};
}

void from_json(const nlohmann::json& j, Lighting& lighting) {
    if (!j.is_object()) throw core::Error("lighting: expected a JSON object");
    read_key(j, "sh", lighting.sh);
    read_key(j, "ambient", lighting.ambient);
    read_key(j, "lights", lighting.lights);
    read_key(j, "specular", lighting.specular);
    read_key(j, "shininess", lighting.shininess);
    read_key(j, "gamma", lighting.gamma);
    read_key(j, "shadows", lighting.shadows);
}

}  // namespace facesynth::render
