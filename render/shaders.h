#pragma once
// Internal: GLSL 3.30 core sources of the renderer's program. Optional parts are compiled in by
// #define (WITH_BARYCENTRICS, WITH_TEXTURE, WITH_LIGHTS) rather than branched on at run time:
// llvmpipe runs both sides of a branch across a SIMD quad, so an unused texture fetch costs.
namespace facesynth::render::detail {

inline constexpr const char* kVertexShader = R"(
layout(location = 0) in vec3 position;
layout(location = 1) in vec3 normal;
layout(location = 2) in vec3 albedo;
layout(location = 3) in vec2 uv;
layout(location = 4) in uint label;
uniform mat4 model_to_clip;
uniform mat4 model_to_camera;
out Varyings {
    vec3 camera_position;
    vec3 camera_normal;
    vec3 albedo;
    vec2 uv;
    flat uint label;
} vs_out;
void main() {
    vec4 p = vec4(position, 1.0);
    gl_Position = model_to_clip * p;
    vs_out.camera_position = (model_to_camera * p).xyz;
    vs_out.camera_normal = mat3(model_to_camera) * normal;
    vs_out.albedo = albedo;
    vs_out.uv = uv;
    vs_out.label = label;
}
)";

inline constexpr const char* kGeometryShader = R"(
layout(triangles) in;
layout(triangle_strip, max_vertices = 3) out;
in Varyings {
    vec3 camera_position;
    vec3 camera_normal;
    vec3 albedo;
    vec2 uv;
    flat uint label;
} gs_in[];
out Varyings {
    vec3 camera_position;
    vec3 camera_normal;
    vec3 albedo;
    vec2 uv;
    flat uint label;
} gs_out;
out vec3 barycentric;  // perspective-correct: the surface weights of the triangle's corners
void main() {
    for (int i = 0; i < 3; ++i) {
        gl_Position = gl_in[i].gl_Position;
        gl_PrimitiveID = gl_PrimitiveIDIn;
        gs_out.camera_position = gs_in[i].camera_position;
        gs_out.camera_normal = gs_in[i].camera_normal;
        gs_out.albedo = gs_in[i].albedo;
        gs_out.uv = gs_in[i].uv;
        gs_out.label = gs_in[i].label;
        barycentric = vec3(i == 0, i == 1, i == 2);
        EmitVertex();
    }
    EndPrimitive();
}
)";

inline constexpr const char* kFragmentShader = R"(
in Varyings {
    vec3 camera_position;
    vec3 camera_normal;
    vec3 albedo;
    vec2 uv;
    flat uint label;
} fs_in;
#ifdef WITH_BARYCENTRICS
in vec3 barycentric;
#endif
uniform vec3 sh[9];            // L_lm · Â_l / π: the sum over Y_lm(n) is irradiance / π
uniform vec3 ambient;
uniform int light_count;
uniform vec3 light_direction[4];  // camera space, unit, toward the light
uniform vec3 light_colour[4];
uniform float specular;
uniform float shininess;
uniform float inverse_gamma;
uniform int perspective;
uniform sampler2D albedo_texture;
layout(location = 0) out vec4 out_colour;
layout(location = 1) out vec4 out_geometry;   // camera z, camera-space normal
layout(location = 2) out uvec2 out_ids;       // triangle id + 1, region label
layout(location = 3) out vec4 out_barycentric;

vec3 sh_irradiance_over_pi(vec3 n) {   // n in view space (x right, y up, z toward the camera)
    return sh[0] * 0.282095
         + sh[1] * (0.488603 * n.y) + sh[2] * (0.488603 * n.z) + sh[3] * (0.488603 * n.x)
         + sh[4] * (1.092548 * n.x * n.y) + sh[5] * (1.092548 * n.y * n.z)
         + sh[6] * (0.315392 * (3.0 * n.z * n.z - 1.0))
         + sh[7] * (1.092548 * n.x * n.z) + sh[8] * (0.546274 * (n.x * n.x - n.y * n.y));
}

void main() {
    vec3 n = normalize(fs_in.camera_normal);
    if (!gl_FrontFacing) n = -n;
#ifdef WITH_TEXTURE
    vec3 albedo = texture(albedo_texture, fs_in.uv).rgb;
#else
    vec3 albedo = fs_in.albedo;
#endif
    vec3 view_normal = vec3(n.x, -n.y, -n.z);
    vec3 diffuse = ambient + max(sh_irradiance_over_pi(view_normal), vec3(0.0));
    vec3 highlight = vec3(0.0);
#ifdef WITH_LIGHTS
    vec3 to_eye = perspective != 0 ? normalize(-fs_in.camera_position) : vec3(0.0, 0.0, -1.0);
    for (int i = 0; i < light_count; ++i) {
        float n_dot_l = dot(n, light_direction[i]);
        if (n_dot_l <= 0.0) continue;
        diffuse += light_colour[i] * n_dot_l;
        vec3 h = normalize(light_direction[i] + to_eye);
        highlight += light_colour[i] * (specular * pow(max(dot(n, h), 0.0), shininess));
    }
#endif
    vec3 linear_rgb = clamp(albedo * diffuse + highlight, 0.0, 1.0);
    out_colour = vec4(pow(linear_rgb, vec3(inverse_gamma)), 1.0);
    out_geometry = vec4(fs_in.camera_position.z, n);
    out_ids = uvec2(uint(gl_PrimitiveID) + 1u, fs_in.label);
#ifdef WITH_BARYCENTRICS
    out_barycentric = vec4(barycentric, 1.0);
#else
    out_barycentric = vec4(0.0);
#endif
}
)";

}  // namespace facesynth::render::detail
