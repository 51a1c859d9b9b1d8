#pragma once
// Internal: GLSL 3.30 core sources of the renderer's program. Optional parts are compiled in by
// #define rather than branched on at run time: llvmpipe runs both sides of a branch across a SIMD
// quad, and every varying costs setup work per triangle and interpolation per pixel.
//   WITH_COLOUR        shade and write out_colour (location 0)
//   WITH_NORMALS       write the camera-space normal (location 1)
//   WITH_IDS           write triangle id + 1 (location 2), from a flat per-vertex attribute
//   WITH_BARYCENTRICS  geometry-shader pass writing barycentrics (location 3)
//   WITH_TEXTURE       albedo from a texture sampled with uv instead of per-vertex albedo
//   WITH_LIGHTS        directional lights with Blinn-Phong specular (per pixel)
//   WITH_SHADOWS       (with WITH_LIGHTS) each light's terms weighted by its shadow-map visibility;
//                      the only variant with the camera-space position as a varying
//   TWO_SIDED          back faces are drawn: SH irradiance per pixel on the flipped normal;
//                      otherwise it is evaluated per vertex (a quadratic in n: interpolating it
//                      differs from per-pixel evaluation by far less than one 8-bit level)
//   PER_PIXEL_COLOUR   albedo · irradiance and the gamma encoding per pixel even where they could be
//                      per vertex (RenderSettings::per_pixel_colour; the reference for the test below)
//   LIGHTS_PER_VERTEX  (with WITH_LIGHTS, one-sided, no shadows: VERTEX_LIGHTS) Gouraud shading of the
//                      directional lights: their diffuse irradiance and specular highlight computed
//                      per vertex and interpolated (RenderSettings::lights_per_vertex). The per-pixel
//                      specular (a normalize and a pow per light and pixel) and the normal varying
//                      were most of a lit render's fragment cost; the albedo and the gamma encoding
//                      stay per pixel, or with a uniform albedo the colour is per vertex as below.
//                      Narrow highlights (nose ridge, lid creases) soften: docs/render.md "Shading".
//   GAMMA_2_2          the lighting's gamma is 2.2 (the default): the per-pixel encoding takes three
//                      square roots instead of a pow (~0.2 of 3.65 CPU ms of the built-in model's lit
//                      256² render); within one level of pow (tests/render/test_fast_gamma.cpp)
// Without a texture, per-pixel lights or TWO_SIDED (and for a uniform albedo: the renderer sets PER_PIXEL_COLOUR
// otherwise) the colour is per vertex (COLOUR_PER_VERTEX): the vertex stage raises albedo · irradiance
// to 2/gamma, and the fragment stage interpolates that and takes its square root, one sqrt instead of a
// pow per pixel and one varying instead of two. For gamma near 2 the interpolated quantity is nearly
// linear in the colour, so this stays within a few levels of per-pixel encoding (at most 7 on random
// views and SH lightings, mean 0.03; tests/render/test_colour_per_vertex.cpp); the write to the 8-bit
// target clamps, as the per-pixel clamp did.
// Camera-space position and depth are not varyings: depth comes from the depth buffer and the
// view ray from gl_FragCoord.
namespace facesynth::render::detail {

// Derived switches, shared by every stage.
inline constexpr const char* kCommonHeader = R"(
#if defined(WITH_COLOUR) && !defined(TWO_SIDED)
#define SH_PER_VERTEX
#endif
#if defined(SH_PER_VERTEX) && defined(WITH_LIGHTS) && defined(LIGHTS_PER_VERTEX) && !defined(WITH_SHADOWS)
#define VERTEX_LIGHTS
#endif
#if defined(WITH_NORMALS) || (defined(WITH_LIGHTS) && !defined(VERTEX_LIGHTS)) || (defined(WITH_COLOUR) && defined(TWO_SIDED))
#define NEEDS_NORMAL
#endif
#if defined(WITH_COLOUR) && defined(WITH_TEXTURE)
#define NEEDS_UV
#endif
#if defined(SH_PER_VERTEX) && !defined(WITH_TEXTURE) && (!defined(WITH_LIGHTS) || defined(VERTEX_LIGHTS)) && !defined(PER_PIXEL_COLOUR)
#define COLOUR_PER_VERTEX
#endif
#if defined(WITH_COLOUR) && !defined(WITH_TEXTURE) && !defined(COLOUR_PER_VERTEX)
#define NEEDS_ALBEDO
#endif
#if defined(SH_PER_VERTEX) && !defined(COLOUR_PER_VERTEX)
#define NEEDS_IRRADIANCE
#endif
#if defined(VERTEX_LIGHTS) && !defined(COLOUR_PER_VERTEX)
#define NEEDS_HIGHLIGHT
#endif
#if defined(WITH_COLOUR) && defined(WITH_LIGHTS) && defined(WITH_SHADOWS)
#define NEEDS_POSITION
#endif
// Members a variant does not use are never written nor read, so the linker drops them.
#define VARYINGS vec3 camera_normal; vec3 albedo; vec2 uv; vec3 irradiance; vec3 highlight; vec3 colour; flat uint triangle; vec3 camera_position;
uniform vec3 sh[9];            // L_lm · Â_l / π: the sum over Y_lm(n) is irradiance / π
uniform vec3 ambient;
uniform float inverse_gamma;
uniform int light_count;
uniform vec3 light_direction[4];  // camera space, unit, toward the light
uniform vec3 light_colour[4];
uniform float specular;
uniform float shininess;
uniform int perspective;
vec3 sh_irradiance_over_pi(vec3 n) {   // n in view space (x right, y up, z toward the camera)
    return sh[0] * 0.282095
         + sh[1] * (0.488603 * n.y) + sh[2] * (0.488603 * n.z) + sh[3] * (0.488603 * n.x)
         + sh[4] * (1.092548 * n.x * n.y) + sh[5] * (1.092548 * n.y * n.z)
         + sh[6] * (0.315392 * (3.0 * n.z * n.z - 1.0))
         + sh[7] * (1.092548 * n.x * n.z) + sh[8] * (0.546274 * (n.x * n.x - n.y * n.y));
}
// Camera axes (x right, y down, z forward) to view axes (x right, y up, z toward the camera).
vec3 view_from_camera(vec3 n) { return vec3(n.x, -n.y, -n.z); }
)";

inline constexpr const char* kVertexShader = R"(
layout(location = 0) in vec3 position;
layout(location = 1) in vec3 normal;
layout(location = 2) in vec3 albedo;
layout(location = 3) in vec2 uv;
layout(location = 4) in uint triangle;  // id + 1 of the triangle this vertex provokes, 0 if none
uniform mat4 model_to_clip;
uniform mat4 model_to_camera;
out Varyings { VARYINGS } vs_out;
void main() {
    gl_Position = model_to_clip * vec4(position, 1.0);
    vec3 camera_normal = mat3(model_to_camera) * normal;
#ifdef NEEDS_NORMAL
    vs_out.camera_normal = camera_normal;
#endif
#ifdef NEEDS_ALBEDO
    vs_out.albedo = albedo;
#endif
#ifdef NEEDS_UV
    vs_out.uv = uv;
#endif
#ifdef SH_PER_VERTEX
    vec3 irradiance = ambient + max(sh_irradiance_over_pi(view_from_camera(normalize(camera_normal))), vec3(0.0));
#endif
#ifdef VERTEX_LIGHTS
    // Gouraud: the directional lights' diffuse and specular terms at the vertex, interpolated.
    vec3 n = normalize(camera_normal);
    vec3 to_eye = perspective != 0 ? -normalize((model_to_camera * vec4(position, 1.0)).xyz) : vec3(0.0, 0.0, -1.0);
    vec3 highlight = vec3(0.0);
    for (int i = 0; i < light_count; ++i) {
        float n_dot_l = dot(n, light_direction[i]);
        if (n_dot_l <= 0.0) continue;
        irradiance += light_colour[i] * n_dot_l;
        vec3 h = normalize(light_direction[i] + to_eye);
        highlight += light_colour[i] * (specular * pow(max(dot(n, h), 0.0), shininess));
    }
#endif
#ifdef NEEDS_IRRADIANCE
    vs_out.irradiance = irradiance;
#endif
#ifdef NEEDS_HIGHLIGHT
    vs_out.highlight = highlight;
#endif
#ifdef COLOUR_PER_VERTEX
    vec3 linear_rgb = albedo * irradiance;
#ifdef VERTEX_LIGHTS
    linear_rgb += highlight;
#endif
    vs_out.colour = pow(max(linear_rgb, vec3(0.0)), vec3(2.0 * inverse_gamma));
#endif
#ifdef WITH_IDS
    vs_out.triangle = triangle;
#endif
#ifdef NEEDS_POSITION
    vs_out.camera_position = (model_to_camera * vec4(position, 1.0)).xyz;
#endif
}
)";

inline constexpr const char* kGeometryShader = R"(
layout(triangles) in;
layout(triangle_strip, max_vertices = 3) out;
in Varyings { VARYINGS } gs_in[];
out Varyings { VARYINGS } gs_out;
out vec3 barycentric;  // perspective-correct: the surface weights of the triangle's corners
void main() {
    for (int i = 0; i < 3; ++i) {
        gl_Position = gl_in[i].gl_Position;
        gs_out.camera_normal = gs_in[i].camera_normal;
        gs_out.albedo = gs_in[i].albedo;
        gs_out.uv = gs_in[i].uv;
        gs_out.irradiance = gs_in[i].irradiance;
        gs_out.highlight = gs_in[i].highlight;
        gs_out.colour = gs_in[i].colour;
        gs_out.triangle = gs_in[i].triangle;
        gs_out.camera_position = gs_in[i].camera_position;
        barycentric = vec3(i == 0, i == 1, i == 2);
        EmitVertex();
    }
    EndPrimitive();
}
)";

inline constexpr const char* kFragmentShader = R"(
in Varyings { VARYINGS } fs_in;
#ifdef WITH_BARYCENTRICS
in vec3 barycentric;
#endif
uniform vec4 window_to_ray;       // (1/fx, 1/fy, cx + 0.5, cy + 0.5): camera ray through a window point
uniform sampler2D albedo_texture;
#ifdef WITH_COLOUR
layout(location = 0) out vec4 out_colour;
#endif
#ifdef WITH_NORMALS
layout(location = 1) out vec4 out_normal;
#endif
#ifdef WITH_IDS
layout(location = 2) out uint out_triangle;
#endif
#ifdef WITH_BARYCENTRICS
layout(location = 3) out vec4 out_barycentric;
#endif

#ifdef NEEDS_POSITION
uniform sampler2DArrayShadow shadow_maps;  // one layer per light, compare mode on
uniform mat4 shadow_from_camera[4];        // camera space to (map s, t, depth) in [0, 1]
uniform float shadow_texel_depth[4];       // one texel's width in map depth units (slope bias)
uniform float shadow_texel;                // 1 / map size
// Share of light i reaching camera-space point p: percentage-closer filtering with 4 bilinear depth
// comparisons at (±1, ±1) texels, i.e. over 4x4 texels (each bilinear tap costs about as much as
// the rest of the shading on llvmpipe: 9 taps cost 1.8x as much for an edge no smoother at 256²).
// The reference depth is pulled toward the light by 3 texels plus 3 texels · tan(angle(n, l)): taps
// up to 2 texels away read the same surface up to 2 · tan texels nearer the light, and facets of
// curved (concave) skin a little more, which without it would shadow lit surfaces (acne). With the
// default map over a head that is ~1.5 mm (1 + tan), too little to detach a shadow from its caster
// visibly at 256² (peter-panning).
float light_visibility(int i, vec3 p, float n_dot_l) {
    vec4 s = shadow_from_camera[i] * vec4(p, 1.0);
    float tan_angle = min(sqrt(max(1.0 - n_dot_l * n_dot_l, 0.0)) / n_dot_l, 8.0);
    float reference = s.z - shadow_texel_depth[i] * (3.0 + 3.0 * tan_angle);
    float lit = 0.0;
    for (int dy = -1; dy <= 1; dy += 2)
        for (int dx = -1; dx <= 1; dx += 2)
            lit += texture(shadow_maps, vec4(s.xy + vec2(dx, dy) * shadow_texel, float(i), reference));
    return lit * 0.25;
}
#endif

// linear^(1/gamma) of a value in [0, 1].
#ifdef GAMMA_2_2
// For gamma 2.2, a sum of powers of x^(1/8) fitted to x^(1/2.2) (minimax by reweighted least squares on
// [1e-8, 1]): three square roots instead of llvmpipe's log2 + exp2, at most 0.017 of an 8-bit level off.
vec3 encode_gamma(vec3 x) {
    vec3 x_half = sqrt(x), x_quarter = sqrt(x_half), x_eighth = sqrt(x_quarter);
    return x_quarter * (-0.0198336506 + 0.286753863 * x_eighth) + x_half * (0.853105568 - 0.120092194 * x_eighth);
}
#else
vec3 encode_gamma(vec3 x) { return pow(x, vec3(inverse_gamma)); }
#endif

void main() {
#ifdef NEEDS_NORMAL
    vec3 n = normalize(fs_in.camera_normal);
    if (!gl_FrontFacing) n = -n;
#endif
#ifdef COLOUR_PER_VERTEX
    out_colour = vec4(sqrt(fs_in.colour), 1.0);
#elif defined(WITH_COLOUR)
#ifdef WITH_TEXTURE
    vec3 albedo = texture(albedo_texture, fs_in.uv).rgb;
#else
    vec3 albedo = fs_in.albedo;
#endif
#ifdef SH_PER_VERTEX
    vec3 diffuse = fs_in.irradiance;
#else
    vec3 diffuse = ambient + max(sh_irradiance_over_pi(view_from_camera(n)), vec3(0.0));
#endif
#ifdef NEEDS_HIGHLIGHT
    vec3 highlight = fs_in.highlight;
#else
    vec3 highlight = vec3(0.0);
#endif
#if defined(WITH_LIGHTS) && !defined(VERTEX_LIGHTS)
    vec3 to_eye = perspective != 0
        ? -normalize(vec3((gl_FragCoord.xy - window_to_ray.zw) * window_to_ray.xy, 1.0))
        : vec3(0.0, 0.0, -1.0);
    for (int i = 0; i < light_count; ++i) {
        float n_dot_l = dot(n, light_direction[i]);
        if (n_dot_l <= 0.0) continue;
#ifdef NEEDS_POSITION
        vec3 light = light_colour[i] * light_visibility(i, fs_in.camera_position, n_dot_l);
#else
        vec3 light = light_colour[i];
#endif
        diffuse += light * n_dot_l;
        vec3 h = normalize(light_direction[i] + to_eye);
        highlight += light * (specular * pow(max(dot(n, h), 0.0), shininess));
    }
#endif
    vec3 linear_rgb = clamp(albedo * diffuse + highlight, 0.0, 1.0);
    out_colour = vec4(encode_gamma(linear_rgb), 1.0);
#endif
#ifdef WITH_NORMALS
    out_normal = vec4(n, 0.0);
#endif
#ifdef WITH_IDS
    out_triangle = fs_in.triangle;
#endif
#ifdef WITH_BARYCENTRICS
    out_barycentric = vec4(barycentric, 1.0);
#endif
}
)";

}  // namespace facesynth::render::detail
