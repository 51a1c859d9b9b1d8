#pragma once
// Lighting parameters: plain structs that serialise to JSON.
//
// Directions are in view space: x toward the image right, y up, z toward the camera (the rotated
// model frame before the camera flip), so a light "from above" has y > 0 whatever the pose.
// Shading (linear RGB, then gamma): albedo · (ambient + E_sh(n) / π + Σ_i c_i max(0, n·l_i))
//                                   + Σ_i c_i · specular · max(0, n·h_i)^shininess
// where E_sh is the irradiance of the second-order spherical-harmonics environment
// (Ramamoorthi & Hanrahan 2001): E(n) = Σ_lm Â_l L_lm Y_lm(n), Â = (π, 2π/3, π/4).
// A uniform environment of radiance L has L_00 = L·√(4π) and shades albedo · L (white furnace).
// With `shadows`, each directional light's diffuse and specular terms are multiplied by its
// visibility from a shadow map (docs/render.md "Shadows"); the SH environment stays unshadowed.
#include <nlohmann/json_fwd.hpp>

#include <array>
#include <vector>

namespace facesynth::render {

struct DirectionalLight {
    std::array<float, 3> direction{0.0f, 0.0f, 1.0f};  // toward the light, view space (normalised on use)
    std::array<float, 3> colour{1.0f, 1.0f, 1.0f};     // linear RGB intensity
};

struct Lighting {
    // Environment radiance SH coefficients L_lm, real basis in the order
    // (0,0) (1,-1) (1,0) (1,1) (2,-2) (2,-1) (2,0) (2,1) (2,2), one RGB triple each.
    // Default: a soft sky, brighter toward the camera and from above (uniform part 0.55).
    std::array<std::array<float, 3>, 9> sh{{{1.95f, 1.95f, 1.95f}, {0.3f, 0.3f, 0.3f}, {0.5f, 0.5f, 0.5f}}};
    std::array<float, 3> ambient{0.0f, 0.0f, 0.0f};  // linear RGB added to the irradiance term
    std::vector<DirectionalLight> lights;           // at most 4
    float specular = 0.0f;                          // Blinn-Phong strength (0 = matte)
    float shininess = 32.0f;
    float gamma = 2.2f;                             // output encoding: linear^(1/gamma); 1 = linear
    bool shadows = false;                           // directional lights cast shadows (shadow maps)
};

// √(4π): the SH DC coefficient of a uniform environment of radiance 1.
inline constexpr float kShUniformDc = 3.5449077f;
// The irradiance-convolved SH coefficients divided by π (Ramamoorthi & Hanrahan): Â_l / π per coefficient.
inline constexpr std::array<float, 9> kShBandScale{1.0f, 2.0f / 3.0f, 2.0f / 3.0f, 2.0f / 3.0f, 0.25f, 0.25f, 0.25f, 0.25f, 0.25f};

[[nodiscard]] Lighting uniform_lighting(float radiance);

// The factor a matte albedo is multiplied by (linear RGB, before gamma) at a surface whose unit normal
// is `view_normal` (view space), unshadowed: ambient + max(E_sh(n) / π, 0) + Σ_i c_i max(0, n·l_i),
// as the renderer shades it.
[[nodiscard]] std::array<float, 3> diffuse_shading(const Lighting& lighting, const std::array<float, 3>& view_normal);

void to_json(nlohmann::json& j, const DirectionalLight& light);
void from_json(const nlohmann::json& j, DirectionalLight& light);
void to_json(nlohmann::json& j, const Lighting& lighting);
// Missing keys keep their defaults; wrong types throw core::Error naming the key.
void from_json(const nlohmann::json& j, Lighting& lighting);

}  // namespace facesynth::render
