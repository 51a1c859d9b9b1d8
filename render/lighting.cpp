#include "render/lighting.h"

#include "core/error.h"

#include <nlohmann/json.hpp>

namespace facesynth::render {

Lighting uniform_lighting(float radiance) {
    Lighting lighting;
    lighting.sh = {};
    lighting.sh[0] = {radiance * kShUniformDc, radiance * kShUniformDc, radiance * kShUniformDc};
    return lighting;
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
