#include "render/renderer.h"

#include "core/error.h"
#include "render/edge_antialiasing.h"
#include "render/gl_context.h"
#include "render/gl_functions.h"
#include "render/gl_program.h"
#include "render/render_targets.h"
#include "render/shaders.h"
#include "render/shadow_maps.h"
#include "render/triangle_list.h"

#include <Eigen/Geometry>
#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <vector>

namespace facesynth::render {

Backend parse_backend(std::string_view name) {
    if (name == "auto") return Backend::kAuto;
    if (name == "egl") return Backend::kEgl;
    if (name == "osmesa") return Backend::kOsmesa;
    throw core::Error("unknown render backend '" + std::string(name) + "' (expected auto, egl or osmesa)");
}

std::string to_string(Backend backend) {
    switch (backend) {
        case Backend::kAuto: return "auto";
        case Backend::kEgl: return "egl";
        case Backend::kOsmesa: return "osmesa";
    }
    return "auto";
}

namespace {

Eigen::Matrix3d model_to_camera_rotation(const morph::CameraPose& pose) { return morph::model_to_camera_flip() * pose.rotation; }

// Model space to camera space (OpenCV axes) as a 4 x 4 matrix.
Eigen::Matrix4d model_to_camera(const Camera& camera) {
    Eigen::Matrix4d m = Eigen::Matrix4d::Identity();
    m.topLeftCorner<3, 3>() = model_to_camera_rotation(camera.pose);
    m.topRightCorner<3, 1>() = camera.pose.translation;
    return m;
}

}  // namespace

Eigen::Vector2d project_point(const Camera& camera, const Eigen::Vector3d& model_point) {
    const Eigen::Vector3d c = to_camera(camera.pose, model_point);
    const morph::Intrinsics& k = camera.intrinsics;
    if (camera.projection == Projection::kOrthographic) return {k.fx * c.x() + k.cx, k.fy * c.y() + k.cy};
    return project(k, c);
}

Eigen::Matrix2Xd project_points(const Camera& camera, const Eigen::Matrix3Xf& model_points) {
    Eigen::Matrix2Xd out(2, model_points.cols());
    for (Eigen::Index i = 0; i < model_points.cols(); ++i)
        out.col(i) = project_point(camera, model_points.col(i).cast<double>());
    return out;
}

namespace {
constexpr std::array<std::pair<Antialiasing::Method, std::string_view>, 4> kAntialiasingNames{{
    {Antialiasing::Method::kNone, "none"},
    {Antialiasing::Method::kMsaa, "msaa"},
    {Antialiasing::Method::kSupersampling, "supersampling"},
    {Antialiasing::Method::kEdges, "edges"},
}};
}  // namespace

std::string_view antialiasing_name(Antialiasing::Method method) {
    for (const auto& [m, name] : kAntialiasingNames)
        if (m == method) return name;
    throw core::Error("render: unknown anti-aliasing method " + std::to_string(static_cast<int>(method)));
}

std::pair<int, int> antialiasing_sample_range(Antialiasing::Method method) {
    switch (method) {
        case Antialiasing::Method::kMsaa: return {2, 16};
        case Antialiasing::Method::kSupersampling: return {2, 4};
        case Antialiasing::Method::kNone:
        case Antialiasing::Method::kEdges: return {1, 1};
    }
    return {1, 1};
}

Antialiasing antialiasing_from(std::string_view name, int samples) {
    const auto known = std::find_if(kAntialiasingNames.begin(), kAntialiasingNames.end(), [&](const auto& entry) { return entry.second == name; });
    if (known == kAntialiasingNames.end())
        throw core::Error("unknown anti-aliasing method '" + std::string(name) + "' (none, msaa, supersampling or edges)");
    const Antialiasing::Method method = known->first;
    const auto [fewest, most] = antialiasing_sample_range(method);
    const int default_samples = method == Antialiasing::Method::kMsaa ? 4 : fewest;
    if (samples == 0) samples = default_samples;
    if (samples < fewest || samples > most) {
        if (fewest == most) throw core::Error(std::string(name) + " anti-aliasing takes no sample count (0 or 1), not " + std::to_string(samples));
        throw core::Error(std::string(name) + " anti-aliasing takes " + std::to_string(fewest) + " to " + std::to_string(most) +
                          " samples (0: " + std::to_string(default_samples) + "), not " + std::to_string(samples));
    }
    return {method, samples};
}

namespace {

using detail::GlFunctions;

// Names of vertex attribute locations (shaders.h).
enum Attribute : GLuint { kPosition = 0, kNormal = 1, kAlbedo = 2, kUv = 3, kTriangle = 4, kNumAttributes = 5 };

constexpr float kDefaultAlbedo = 0.7f;
// The gamma whose per-pixel encoding has a cheaper exact-enough form (shaders.h GAMMA_2_2).
constexpr float kFastGamma = 2.2f;

// The same view `factor` times larger: pixel (u, v) covers fine pixels factor·u .. factor·u + factor − 1,
// i.e. fine = factor · (coarse + 0.5) − 0.5 in OpenCV pixel coordinates (centre of pixel 0 at 0).
Camera supersampled_camera(const Camera& camera, int factor) {
    Camera fine = camera;
    morph::Intrinsics& k = fine.intrinsics;
    const double f = factor;
    k.width *= factor;
    k.height *= factor;
    k.fx *= f;
    k.fy *= f;
    k.cx = f * (k.cx + 0.5) - 0.5;
    k.cy = f * (k.cy + 0.5) - 0.5;
    return fine;
}

// Shader variants: bit flags compiled in with #define (shaders.h).
enum Variant : unsigned {
    kWithColour = 1, kWithNormals = 2, kWithIds = 4, kWithBarycentrics = 8, kWithTexture = 16, kWithLights = 32,
    kTwoSided = 64, kWithShadows = 128, kPerPixelColour = 256, kLightsPerVertex = 512, kGamma22 = 1024,
    kNumVariants = 2048
};
// No outputs: the depth-only pass that fills a shadow map.
constexpr unsigned kDepthOnly = 0;

GLuint link_program(const GlFunctions& gl, unsigned variant) {
    const bool with_barycentrics = (variant & kWithBarycentrics) != 0;
    std::string header = "#version 330 core\n";
    const std::pair<Variant, const char*> defines[] = {
        {kWithColour, "WITH_COLOUR"}, {kWithNormals, "WITH_NORMALS"}, {kWithIds, "WITH_IDS"},
        {kWithBarycentrics, "WITH_BARYCENTRICS"}, {kWithTexture, "WITH_TEXTURE"}, {kWithLights, "WITH_LIGHTS"},
        {kTwoSided, "TWO_SIDED"}, {kWithShadows, "WITH_SHADOWS"}, {kPerPixelColour, "PER_PIXEL_COLOUR"},
        {kLightsPerVertex, "LIGHTS_PER_VERTEX"}, {kGamma22, "GAMMA_2_2"}};
    for (const auto& [bit, name] : defines)
        if (variant & bit) header += std::string("#define ") + name + "\n";
    header += detail::kCommonHeader;
    std::vector<GLuint> shaders{detail::compile_shader(gl, GL_VERTEX_SHADER, header + detail::kVertexShader),
                                detail::compile_shader(gl, GL_FRAGMENT_SHADER, header + detail::kFragmentShader)};
    if (with_barycentrics)
        shaders.push_back(detail::compile_shader(gl, GL_GEOMETRY_SHADER, header + detail::kGeometryShader));
    return detail::link_shaders(gl, shaders);
}

}  // namespace

// Members of Renderer::Impl, a class with linkage: kept out of the anonymous namespace (a unity
// build would otherwise warn that Impl's fields have types without linkage).
namespace detail {

// The mesh's triangle list re-indexed so that every triangle has a provoking vertex of its own
// (OpenGL's last-vertex convention): its flat `triangle` attribute then names the triangle without
// gl_PrimitiveID, which makes Mesa's draw module assemble primitives one by one. A triangle's last
// vertex serves when no earlier triangle took it; otherwise a copy of that vertex is appended, so
// positions (and rasterisation) are unchanged. Built once per distinct triangle list.
struct ProvokingTopology {
    detail::TriangleListKey source;      // the mesh's triangle list it was built from
    std::vector<GLuint> indices;         // 3 per triangle, same order and corner order as `source`
    std::vector<int> copied_from;        // for vertex slot source.vertices() + i: the vertex it copies
    std::vector<GLuint> triangle_of_slot;  // id + 1 of the triangle a slot provokes, 0 if none

    [[nodiscard]] bool matches(const morph::Mesh& mesh) const { return source.matches(mesh); }
    [[nodiscard]] int slots() const { return source.vertices() + static_cast<int>(copied_from.size()); }

    void build(const morph::Mesh& mesh) {
        source.assign(mesh);
        const std::vector<morph::Triangle>& triangles = source.triangles();
        indices.clear();
        indices.reserve(3 * triangles.size());
        copied_from.clear();
        triangle_of_slot.assign(static_cast<std::size_t>(source.vertices()), 0u);
        for (std::size_t t = 0; t < triangles.size(); ++t) {
            const morph::Triangle& tri = triangles[t];
            GLuint provoking = static_cast<GLuint>(tri[2]);
            if (triangle_of_slot[provoking] != 0) {
                provoking = static_cast<GLuint>(triangle_of_slot.size());
                copied_from.push_back(tri[2]);
                triangle_of_slot.push_back(0u);
            }
            triangle_of_slot[provoking] = static_cast<GLuint>(t + 1);
            indices.insert(indices.end(), {static_cast<GLuint>(tri[0]), static_cast<GLuint>(tri[1]), provoking});
        }
    }

    // Per-vertex columns of `values` (rows x source.vertices(), column-major) extended to every slot.
    void expand(const float* values, int rows, std::vector<float>& out) const {
        const std::size_t n = static_cast<std::size_t>(rows) * static_cast<std::size_t>(source.vertices());
        out.resize(static_cast<std::size_t>(rows) * static_cast<std::size_t>(slots()));
        std::copy(values, values + n, out.begin());
        float* copy = out.data() + n;
        // An element loop: std::copy of 2 or 3 floats becomes a memmove call per copied vertex.
        for (int from : copied_from) {
            const float* src = values + static_cast<std::ptrdiff_t>(rows) * from;
            for (int r = 0; r < rows; ++r) *copy++ = src[r];
        }
    }
};

struct Program {
    GLuint id = 0;
    GLint model_to_clip = -1, model_to_camera = -1, sh = -1, ambient = -1, light_count = -1, light_direction = -1,
          light_colour = -1, specular = -1, shininess = -1, inverse_gamma = -1, perspective = -1,
          window_to_ray = -1, albedo_texture = -1, shadow_maps = -1, shadow_from_camera = -1, shadow_texel_depth = -1,
          shadow_texel = -1;

    void locate(const GlFunctions& gl) {
        auto at = [&](const char* name) { return gl.GetUniformLocation(id, name); };
        model_to_clip = at("model_to_clip");
        model_to_camera = at("model_to_camera");
        sh = at("sh");
        ambient = at("ambient");
        light_count = at("light_count");
        light_direction = at("light_direction");
        light_colour = at("light_colour");
        specular = at("specular");
        shininess = at("shininess");
        inverse_gamma = at("inverse_gamma");
        perspective = at("perspective");
        window_to_ray = at("window_to_ray");
        albedo_texture = at("albedo_texture");
        shadow_maps = at("shadow_maps");
        shadow_from_camera = at("shadow_from_camera");
        shadow_texel_depth = at("shadow_texel_depth");
        shadow_texel = at("shadow_texel");
    }
};
}  // namespace detail
using detail::Program;
using detail::ProvokingTopology;

namespace {

// Directional lights in camera space (OpenCV axes), unit, toward the light.
std::vector<Eigen::Vector3d> light_directions_in_camera(const Lighting& lighting) {
    if (lighting.lights.size() > 4) throw core::Error("render: at most 4 directional lights are supported");
    std::vector<Eigen::Vector3d> directions;
    for (std::size_t i = 0; i < lighting.lights.size(); ++i) {
        const auto& d = lighting.lights[i].direction;
        const Eigen::Vector3d view(d[0], d[1], d[2]);
        if (view.norm() == 0) throw core::Error("render: directional light " + std::to_string(i) + " has a zero direction");
        directions.emplace_back(morph::model_to_camera_flip() * view.normalized());
    }
    return directions;
}

}  // namespace

// RGBA8 to RGB8 + the alpha plane: cv::mixChannels' generic path cost ~18 instructions per pixel
// (5 % of a 256² render); cvtColor's SIMD path and a loop the compiler vectorises cost about one.
void split_colour_and_coverage(const cv::Mat& rgba, cv::Mat& rgb, cv::Mat& alpha) {
    cv::cvtColor(rgba, rgb, cv::COLOR_RGBA2RGB);
    const int rows = rgba.rows, columns = rgba.cols;  // not reloaded through the aliasing byte stores
    for (int y = 0; y < rows; ++y) {
        const std::uint8_t* in = rgba.ptr<std::uint8_t>(y);
        std::uint8_t* coverage = alpha.ptr<std::uint8_t>(y);
        for (int x = 0; x < columns; ++x) coverage[x] = in[4 * x + 3];
    }
}

// No mesh colours (the default grey) or the same colour at every vertex: then only the smooth SH
// irradiance varies across a triangle, and the encoded colour may be interpolated from the vertices
// (shaders.h COLOUR_PER_VERTEX). Where the albedo varies, interpolating it after the per-vertex power
// shifts sharp features (the built-in model's iris, lids and hairline: up to 64 levels under strong
// light), so those meshes keep the per-pixel encoding.
bool uniform_albedo(const morph::Mesh& mesh) {
    if (mesh.colours.cols() == 0) return true;
    const Eigen::Vector3f first = mesh.colours.col(0);
    for (Eigen::Index i = 1; i < mesh.colours.cols(); ++i)
        if (mesh.colours.col(i) != first) return false;
    return true;
}

using detail::Target;
using detail::kColourTarget;
using detail::kNormalTarget;
using detail::kIdTarget;
using detail::kBarycentricTarget;

struct Renderer::Impl {
    std::unique_ptr<detail::GlContext> context;
    GlFunctions gl;
    std::string renderer_string;
    std::array<detail::Program, kNumVariants> programs{};  // linked on first use
    GLuint vao = 0;
    std::array<GLuint, kNumAttributes> vertex_buffers{};
    std::array<std::size_t, kNumAttributes> buffer_bytes{};  // allocated size of each vertex buffer
    GLuint index_buffer = 0;
    GLuint texture = 0;
    int texture_width = 0, texture_height = 0;
    detail::RenderTargets targets{gl};
    cv::Mat fine_rgba;  // the supersampled pass's read-back before the box filter
    EdgeAntialiasing edge_antialiasing;  // silhouette edges of the last triangle list, with scratch
    cv::Mat edge_depth;                  // the depth it needs when the frame has none (geometry off)
    int width = 0, height = 0;  // this render's image: the bottom-left corner of the targets
    int max_texture_size = 0;
    detail::ProvokingTopology topology;
    Eigen::Vector3f mesh_low, mesh_high;  // bounding box of the uploaded positions
    Eigen::Matrix3Xf normals;
    std::vector<float> expanded;  // one attribute extended to every vertex slot
    std::vector<std::uint8_t> triangle_labels;
    cv::Mat rgba;                 // 8-bit colour + coverage read-back
    cv::Mat vectors;              // RGBA float read-back (normals, barycentrics)
    detail::ShadowMaps shadow_maps{gl};  // created on the first render with shadows, kept for later ones
    double near_plane = 0, far_plane = 0;
    bool perspective = true;

    explicit Impl(const RendererOptions& options) {
        context = detail::open_context(options);
        context->make_current();
        renderer_string = detail::load_functions(*context, gl);
        int max_samples = 0;
        gl.GetIntegerv(GL_MAX_SAMPLES, &max_samples);
        gl.GetIntegerv(GL_MAX_TEXTURE_SIZE, &max_texture_size);
        (void)program(kWithColour | kWithIds);
        gl.GenVertexArrays(1, &vao);
        gl.GenBuffers(static_cast<GLsizei>(vertex_buffers.size()), vertex_buffers.data());
        gl.GenBuffers(1, &index_buffer);
        gl.GenTextures(1, &texture);
        targets.create(max_samples);
        gl.BindVertexArray(vao);
        gl.BindBuffer(GL_ELEMENT_ARRAY_BUFFER, index_buffer);
        gl.Enable(GL_DEPTH_TEST);
        gl.Enable(GL_SCISSOR_TEST);  // clears and blits stay inside the image (ensure_targets)
        gl.DepthFunc(GL_LESS);
        // Image rows run down the GL rows (clip_from_camera), which mirrors the winding: the
        // counter-clockwise front faces arrive clockwise.
        gl.FrontFace(GL_CW);
        gl.CullFace(GL_BACK);
        gl.ProvokingVertex(GL_LAST_VERTEX_CONVENTION);  // ProvokingTopology relies on it
        gl.PixelStorei(GL_PACK_ALIGNMENT, 1);
        gl.PixelStorei(GL_UNPACK_ALIGNMENT, 1);
        check("initialisation");
        // Free for any thread: render() binds the context where it runs.
        context->release();
    }

    ~Impl() {
        if (!context) return;
        try {
            context->make_current();
        } catch (const core::Error&) {
            return;  // the context goes with it
        }
        targets.release();
        gl.DeleteTextures(1, &texture);
        shadow_maps.release();
        gl.DeleteBuffers(1, &index_buffer);
        gl.DeleteBuffers(static_cast<GLsizei>(vertex_buffers.size()), vertex_buffers.data());
        gl.DeleteVertexArrays(1, &vao);
        for (const Program& p : programs)
            if (p.id) gl.DeleteProgram(p.id);
        context->release();
    }

    const Program& program(unsigned variant) {
        Program& p = programs.at(variant);
        if (p.id == 0) {
            p.id = link_program(gl, variant);
            p.locate(gl);
        }
        return p;
    }

    void check(const char* stage) const { detail::check_gl(gl, stage); }

    // The targets for this render's w x h image (drawn into their bottom-left corner).
    void ensure_targets(int w, int h, int sample_count) {
        targets.ensure(w, h, sample_count);
        width = w;
        height = h;
    }

    // Vertex buffers keep their storage between renders; data of the same size is replaced in place.
    void upload(Attribute attribute, const void* data, std::size_t bytes, GLint components, GLenum type) {
        gl.BindBuffer(GL_ARRAY_BUFFER, vertex_buffers[attribute]);
        if (buffer_bytes[attribute] == bytes) {
            gl.BufferSubData(GL_ARRAY_BUFFER, 0, static_cast<GLsizeiptr>(bytes), data);
        } else {
            gl.BufferData(GL_ARRAY_BUFFER, static_cast<GLsizeiptr>(bytes), data, GL_DYNAMIC_DRAW);
            buffer_bytes[attribute] = bytes;
        }
        if (type == GL_UNSIGNED_INT)
            gl.VertexAttribIPointer(attribute, components, type, 0, nullptr);
        else
            gl.VertexAttribPointer(attribute, components, type, GL_FALSE, 0, nullptr);
        gl.EnableVertexAttribArray(attribute);
    }

    void upload_expanded(Attribute attribute, const float* values, int rows) {
        topology.expand(values, rows, expanded);
        upload(attribute, expanded.data(), sizeof(float) * expanded.size(), rows, GL_FLOAT);
    }

    void upload_positions(const morph::Mesh& mesh) {
        if (!topology.matches(mesh)) {
            topology.build(mesh);
            gl.BufferData(GL_ELEMENT_ARRAY_BUFFER, static_cast<GLsizeiptr>(sizeof(GLuint) * topology.indices.size()),
                          topology.indices.data(), GL_STATIC_DRAW);
            upload(kTriangle, topology.triangle_of_slot.data(), sizeof(GLuint) * topology.triangle_of_slot.size(), 1,
                   GL_UNSIGNED_INT);
        }
        upload_expanded(kPosition, mesh.vertices.data(), 3);
        // One pass over the columns: Eigen's row-wise reductions of a 3xN matrix cost several times more.
        mesh_low = mesh_high = mesh.vertices.col(0);
        for (Eigen::Index i = 1; i < mesh.vertices.cols(); ++i) {
            mesh_low = mesh_low.cwiseMin(mesh.vertices.col(i));
            mesh_high = mesh_high.cwiseMax(mesh.vertices.col(i));
        }
    }

    // A depth-only pass reads positions only; the other arrays are switched off so that no stale buffer
    // of another mesh is fetched from (the next full render uploads and enables them again).
    void disable_surface_attributes() {
        for (Attribute attribute : {kNormal, kAlbedo, kUv}) gl.DisableVertexAttribArray(attribute);
    }

    void upload_mesh(const morph::Mesh& mesh, const MeshExtras& extras, bool with_texture) {
        upload_positions(mesh);
        normals = morph::vertex_normals(mesh.vertices, mesh.triangles);
        upload_expanded(kNormal, normals.data(), 3);
        if (mesh.colours.cols() == mesh.num_vertices()) {
            upload_expanded(kAlbedo, mesh.colours.data(), 3);
        } else {
            gl.DisableVertexAttribArray(kAlbedo);
            gl.VertexAttrib3f(kAlbedo, kDefaultAlbedo, kDefaultAlbedo, kDefaultAlbedo);
        }
        if (with_texture) {
            upload_expanded(kUv, mesh.uv.data(), 2);
            const cv::Mat& t = *extras.texture;
            const cv::Mat continuous = t.isContinuous() ? t : t.clone();
            gl.ActiveTexture(GL_TEXTURE0);
            gl.BindTexture(GL_TEXTURE_2D, texture);
            // A texture of the same size replaces the texels in place (no new storage per frame).
            if (t.cols == texture_width && t.rows == texture_height) {
                gl.TexSubImage2D(GL_TEXTURE_2D, 0, 0, 0, t.cols, t.rows, GL_RGB, GL_UNSIGNED_BYTE, continuous.data);
            } else {
                gl.TexImage2D(GL_TEXTURE_2D, 0, GL_SRGB8, t.cols, t.rows, 0, GL_RGB, GL_UNSIGNED_BYTE, continuous.data);
                texture_width = t.cols;
                texture_height = t.rows;
            }
            gl.TexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MIN_FILTER, GL_LINEAR);
            gl.TexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAG_FILTER, GL_LINEAR);
            gl.TexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_S, GL_CLAMP_TO_EDGE);
            gl.TexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_T, GL_CLAMP_TO_EDGE);
        } else {
            gl.DisableVertexAttribArray(kUv);
            gl.VertexAttrib2f(kUv, 0.0f, 0.0f);
        }
        // Labels are flat per triangle, from its provoking (last) vertex: looked up from the ids, which
        // are written as triangle + 1 (0 = background).
        triangle_labels.resize(mesh.triangles.size() + 1);
        triangle_labels[0] = static_cast<std::uint8_t>(morph::Region::kBackground);
        for (std::size_t t = 0; t < mesh.triangles.size(); ++t)
            triangle_labels[t + 1] = extras.vertex_labels.empty()
                                         ? static_cast<std::uint8_t>(morph::Region::kSkin)
                                         : extras.vertex_labels[static_cast<std::size_t>(mesh.triangles[t][2])];
    }

    // Near and far planes from the bounding sphere of the uploaded mesh (upload_positions), with a margin.
    void choose_depth_range(const Camera& camera) {
        perspective = camera.projection == Projection::kPerspective;
        const detail::DepthRange range = detail::depth_range(camera, mesh_low, mesh_high);
        near_plane = range.near;
        far_plane = range.far;
    }

    void set_uniforms(const Program& program, const Camera& camera, const Lighting& lighting) {
        const Eigen::Matrix4d to_camera = model_to_camera(camera);
        choose_depth_range(camera);
        const Eigen::Matrix4f model_to_clip = (detail::clip_from_camera(camera, near_plane, far_plane) * to_camera).cast<float>();
        const Eigen::Matrix4f model_to_camera_f = to_camera.cast<float>();
        gl.UseProgram(program.id);
        gl.UniformMatrix4fv(program.model_to_clip, 1, GL_FALSE, model_to_clip.data());
        gl.UniformMatrix4fv(program.model_to_camera, 1, GL_FALSE, model_to_camera_f.data());
        std::array<float, 27> sh{};
        for (std::size_t k = 0; k < 9; ++k)
            for (std::size_t c = 0; c < 3; ++c) sh[3 * k + c] = lighting.sh[k][c] * kShBandScale[k];
        gl.Uniform3fv(program.sh, 9, sh.data());
        gl.Uniform3fv(program.ambient, 1, lighting.ambient.data());
        std::array<float, 12> directions{}, colours{};
        const std::vector<Eigen::Vector3d> toward_lights = light_directions_in_camera(lighting);
        for (std::size_t i = 0; i < toward_lights.size(); ++i)
            for (std::size_t c = 0; c < 3; ++c) {
                directions[3 * i + c] = static_cast<float>(toward_lights[i][static_cast<Eigen::Index>(c)]);
                colours[3 * i + c] = lighting.lights[i].colour[c];
            }
        gl.Uniform1i(program.light_count, static_cast<GLint>(lighting.lights.size()));
        gl.Uniform3fv(program.light_direction, 4, directions.data());
        gl.Uniform3fv(program.light_colour, 4, colours.data());
        gl.Uniform1f(program.specular, lighting.specular);
        gl.Uniform1f(program.shininess, lighting.shininess);
        if (!(lighting.gamma > 0)) throw core::Error("render: gamma must be positive");
        gl.Uniform1f(program.inverse_gamma, 1.0f / lighting.gamma);
        gl.Uniform1i(program.perspective, perspective ? 1 : 0);
        const morph::Intrinsics& k = camera.intrinsics;
        const std::array<float, 4> window_to_ray{static_cast<float>(1.0 / k.fx), static_cast<float>(1.0 / k.fy),
                                                 static_cast<float>(k.cx + 0.5), static_cast<float>(k.cy + 0.5)};
        gl.Uniform4fv(program.window_to_ray, 1, window_to_ray.data());
        gl.Uniform1i(program.albedo_texture, 0);
        if (program.shadow_maps >= 0) {
            gl.Uniform1i(program.shadow_maps, detail::kShadowTextureUnit);
            gl.UniformMatrix4fv(program.shadow_from_camera, 4, GL_FALSE, shadow_maps.lookup_from_camera().data());
            gl.Uniform1fv(program.shadow_texel_depth, 4, shadow_maps.texel_depth().data());
            gl.Uniform1f(program.shadow_texel, 1.0f / static_cast<float>(shadow_maps.size()));
        }
    }

    [[nodiscard]] GLsizei index_count() const { return static_cast<GLsizei>(topology.indices.size()); }

    void draw() { gl.DrawElements(GL_TRIANGLES, index_count(), GL_UNSIGNED_INT, nullptr); }

    void render(const morph::Mesh& mesh, const Camera& camera, const RenderSettings& settings, Frame& frame,
                const MeshExtras& extras) {
        validate(mesh, camera, settings, extras);
        context->make_current();
        if (settings.depth_only) {
            render_depth(mesh, camera, settings, frame);
            return;
        }
        const int w = camera.intrinsics.width, h = camera.intrinsics.height;
        const bool supersampled = settings.antialiasing.method == Antialiasing::Method::kSupersampling;
        ensure_targets(w, h, settings.antialiasing.msaa_samples());
        gl.BindVertexArray(vao);
        const bool with_texture = extras.texture != nullptr;
        upload_mesh(mesh, extras, with_texture);
        const bool with_shadows = settings.lighting.shadows && !settings.lighting.lights.empty();
        if (with_shadows) {
            const Program& depth_only = program(kDepthOnly);
            shadow_maps.render(mesh.vertices, model_to_camera(camera), light_directions_in_camera(settings.lighting), settings.shadow_map_size,
                               max_texture_size, depth_only.id, depth_only.model_to_clip, index_count());
            gl.Scissor(0, 0, width, height);
            check("rendering shadow maps");
        }
        if (settings.cull_back_faces)
            gl.Enable(GL_CULL_FACE);
        else
            gl.Disable(GL_CULL_FACE);
        gl.Viewport(0, 0, w, h);
        // Gouraud lights only where the vertex stage shades: shadows and two-sided drawing keep them per pixel.
        const bool lights_per_vertex = settings.lights_per_vertex && !settings.lighting.lights.empty() && !with_shadows &&
                                       settings.cull_back_faces;
        const unsigned shading = (with_texture ? kWithTexture : 0u) | (settings.lighting.lights.empty() ? 0u : kWithLights) |
                                 (settings.cull_back_faces ? 0u : kTwoSided) | (with_shadows ? kWithShadows : 0u) |
                                 (settings.per_pixel_colour || !uniform_albedo(mesh) ? kPerPixelColour : 0u) |
                                 (lights_per_vertex ? kLightsPerVertex : 0u) |
                                 (settings.lighting.gamma == kFastGamma ? kGamma22 : 0u);
        const bool multisampled = targets.samples() > 1;
        const bool separate_colour_pass = multisampled || supersampled;
        const bool with_normals = settings.geometry && settings.normals;
        const bool with_ids = settings.geometry || settings.barycentrics;
        // Pass 1, single-sampled at pixel centres: depth, normals, ids, barycentrics, and colour
        // unless a multisampled or supersampled pass makes it.
        const unsigned geometry_outputs = (with_normals ? kWithNormals : 0u) | (with_ids ? kWithIds : 0u) |
                                          (settings.barycentrics ? kWithBarycentrics : 0u);
        const bool single_sample_pass = !separate_colour_pass || geometry_outputs != 0;
        const float zeros[4] = {0, 0, 0, 0};
        const GLuint zero_ids[4] = {0, 0, 0, 0};
        const float far_depth = 1.0f;
        if (single_sample_pass) {
            const unsigned variant = geometry_outputs | (separate_colour_pass ? 0u : kWithColour | shading);
            set_uniforms(program(variant), camera, settings.lighting);
            gl.BindFramebuffer(GL_FRAMEBUFFER, targets.single_sample());
            const GLenum buffers[4] = {separate_colour_pass ? GLenum(GL_NONE) : GLenum(GL_COLOR_ATTACHMENT0),
                                       with_normals ? GLenum(GL_COLOR_ATTACHMENT1) : GLenum(GL_NONE),
                                       with_ids ? GLenum(GL_COLOR_ATTACHMENT2) : GLenum(GL_NONE),
                                       settings.barycentrics ? GLenum(GL_COLOR_ATTACHMENT3) : GLenum(GL_NONE)};
            gl.DrawBuffers(4, buffers);
            if (!separate_colour_pass) gl.ClearBufferfv(GL_COLOR, kColourTarget, zeros);
            if (with_normals) gl.ClearBufferfv(GL_COLOR, kNormalTarget, zeros);
            if (with_ids) gl.ClearBufferuiv(GL_COLOR, kIdTarget, zero_ids);
            if (settings.barycentrics) gl.ClearBufferfv(GL_COLOR, kBarycentricTarget, zeros);
            gl.ClearBufferfv(GL_DEPTH, 0, &far_depth);
            draw();
        }
        if (multisampled) {
            set_uniforms(program(kWithColour | shading), camera, settings.lighting);
            gl.BindFramebuffer(GL_FRAMEBUFFER, targets.multisample());
            const GLenum buffer = GL_COLOR_ATTACHMENT0;
            gl.DrawBuffers(1, &buffer);
            gl.ClearBufferfv(GL_COLOR, 0, zeros);
            gl.ClearBufferfv(GL_DEPTH, 0, &far_depth);
            draw();
            gl.BindFramebuffer(GL_READ_FRAMEBUFFER, targets.multisample());
            gl.BindFramebuffer(GL_DRAW_FRAMEBUFFER, targets.single_sample());
            gl.ReadBuffer(GL_COLOR_ATTACHMENT0);
            gl.DrawBuffers(1, &buffer);
            gl.BlitFramebuffer(0, 0, w, h, 0, 0, w, h, GL_COLOR_BUFFER_BIT, GL_NEAREST);
        }
        if (supersampled) render_supersampled_colour(camera, settings, shading);
        gl.BindFramebuffer(GL_FRAMEBUFFER, targets.single_sample());
        read_back(settings, with_normals, with_ids, !supersampled, !separate_colour_pass, frame);
        if (settings.antialiasing.method == Antialiasing::Method::kEdges) antialias_edges(mesh, camera, settings, frame);
        check("rendering");
    }

    // After the single-sample read-back: blends the pixels cut by visible silhouette edges.
    void antialias_edges(const morph::Mesh& mesh, const Camera& camera, const RenderSettings& settings, Frame& frame) {
        if (!settings.geometry) read_depth(edge_depth);
        (void)edge_antialiasing.apply(mesh, camera, settings.cull_back_faces, settings.geometry ? frame.depth : edge_depth,
                                      frame.rgb, frame.mask);
    }

    // Colour and coverage at `factor`² samples per pixel (an ordered grid): the image rendered
    // `factor` times larger without MSAA, read back and box-filtered into `rgba` (cv::INTER_AREA averages
    // each factor x factor block). Colours are premultiplied by coverage, so the average is the
    // anti-aliased composite over black.
    void render_supersampled_colour(const Camera& camera, const RenderSettings& settings, unsigned shading) {
        const int factor = settings.antialiasing.supersampling_factor();
        const Camera fine = supersampled_camera(camera, factor);
        const int fine_width = fine.intrinsics.width, fine_height = fine.intrinsics.height;
        targets.ensure_supersampled(fine_width, fine_height);
        set_uniforms(program(kWithColour | shading), fine, settings.lighting);
        gl.BindFramebuffer(GL_FRAMEBUFFER, targets.supersample());
        gl.Viewport(0, 0, fine_width, fine_height);
        gl.Scissor(0, 0, fine_width, fine_height);
        const GLenum buffer = GL_COLOR_ATTACHMENT0;
        gl.DrawBuffers(1, &buffer);
        const float zeros[4] = {0, 0, 0, 0};
        const float far_depth = 1.0f;
        gl.ClearBufferfv(GL_COLOR, 0, zeros);
        gl.ClearBufferfv(GL_DEPTH, 0, &far_depth);
        draw();
        fine_rgba.create(fine_height, fine_width, CV_8UC4);
        gl.ReadBuffer(GL_COLOR_ATTACHMENT0);
        gl.ReadPixels(0, 0, fine_width, fine_height, GL_RGBA, GL_UNSIGNED_BYTE, fine_rgba.data);
        rgba.create(height, width, CV_8UC4);
        cv::resize(fine_rgba, rgba, rgba.size(), 0, 0, cv::INTER_AREA);
        gl.Viewport(0, 0, width, height);
        gl.Scissor(0, 0, width, height);
    }

    // The nearest surface only: the fragment stage writes nothing, and only the depth buffer is read.
    void render_depth(const morph::Mesh& mesh, const Camera& camera, const RenderSettings& settings, Frame& frame) {
        const int w = camera.intrinsics.width, h = camera.intrinsics.height;
        ensure_targets(w, h, 0);
        gl.BindVertexArray(vao);
        upload_positions(mesh);
        disable_surface_attributes();
        if (settings.cull_back_faces)
            gl.Enable(GL_CULL_FACE);
        else
            gl.Disable(GL_CULL_FACE);
        gl.Viewport(0, 0, w, h);
        set_uniforms(program(0), camera, settings.lighting);
        gl.BindFramebuffer(GL_FRAMEBUFFER, targets.single_sample());
        const GLenum none[4] = {GL_NONE, GL_NONE, GL_NONE, GL_NONE};
        gl.DrawBuffers(4, none);
        const float far_depth = 1.0f;
        gl.ClearBufferfv(GL_DEPTH, 0, &far_depth);
        draw();
        read_depth(frame.depth);
        for (cv::Mat* unused : {&frame.rgb, &frame.mask, &frame.normals, &frame.triangle_ids, &frame.labels, &frame.barycentrics})
            unused->release();
        check("depth rendering");
    }

    // Camera-space z from the depth buffer's window depth d in [0, 1]: the inverse of the
    // projection's z row (clip_from_camera); background (d = 1) becomes 0.
    void read_depth(cv::Mat& depth) {
        depth.create(height, width, CV_32FC1);
        gl.ReadPixels(0, 0, width, height, GL_DEPTH_COMPONENT, GL_FLOAT, depth.data);
        const double n = near_plane, f = far_plane;
        const auto fn = static_cast<float>(f * n), f_ = static_cast<float>(f), range = static_cast<float>(f - n),
                   n_ = static_cast<float>(n);
        // z is computed for every pixel and the background (d = 1) masked to 0 with an integer
        // comparison of d's bits (|d| < 1): a float comparison may trap, so the compiler would keep
        // a branch per pixel instead of vectorising the loop.
        auto keep_mask = [](float d) {
            return (std::bit_cast<std::uint32_t>(d) & 0x7fffffffu) < std::bit_cast<std::uint32_t>(1.0f) ? ~0u : 0u;
        };
        const int rows = height, columns = width;
        for (int y = 0; y < rows; ++y) {
            float* row = depth.ptr<float>(y);
            if (perspective)
                for (int x = 0; x < columns; ++x) {
                    const float z = fn / (f_ - range * row[x]);
                    row[x] = std::bit_cast<float>(std::bit_cast<std::uint32_t>(z) & keep_mask(row[x]));
                }
            else
                for (int x = 0; x < columns; ++x) {
                    const float z = n_ + range * row[x];
                    row[x] = std::bit_cast<float>(std::bit_cast<std::uint32_t>(z) & keep_mask(row[x]));
                }
        }
    }

    // Triangle ids (written + 1, 0 = background) and the labels of their triangles; with `mask`, also
    // the coverage of a single-sample colour pass, 255 exactly where a triangle was drawn (the colour
    // and id targets are written by the same fragments), which spares a pass over the RGBA alpha.
    void read_ids(cv::Mat& triangle_ids, cv::Mat& labels, cv::Mat* mask) {
        triangle_ids.create(height, width, CV_32SC1);
        labels.create(height, width, CV_8UC1);
        gl.ReadBuffer(GL_COLOR_ATTACHMENT0 + kIdTarget);
        gl.ReadPixels(0, 0, width, height, GL_RED_INTEGER, GL_UNSIGNED_INT, triangle_ids.data);
        // triangle_labels[0] is the background's label, so the written id (triangle + 1) indexes it directly.
        const std::uint8_t* label_of_written_id = triangle_labels.data();
        // Local bounds: the byte stores may alias the members, which would be reloaded every pixel
        // and keep the loops from being vectorised.
        const int rows = height, columns = width;
        for (int y = 0; y < rows; ++y) {
            int* id = triangle_ids.ptr<int>(y);
            std::uint8_t* label = labels.ptr<std::uint8_t>(y);
            for (int x = 0; x < columns; ++x) label[x] = label_of_written_id[id[x]];
            if (mask != nullptr) {
                std::uint8_t* coverage = mask->ptr<std::uint8_t>(y);
                for (int x = 0; x < columns; ++x) coverage[x] = id[x] != 0 ? 255 : 0;
            }
            for (int x = 0; x < columns; ++x) id[x] -= 1;
        }
    }

    // The first three channels of an RGBA float target.
    void read_vectors(Target target, cv::Mat& out) {
        vectors.create(height, width, CV_32FC4);
        gl.ReadBuffer(GL_COLOR_ATTACHMENT0 + static_cast<GLenum>(target));
        gl.ReadPixels(0, 0, width, height, GL_RGBA, GL_FLOAT, vectors.data);
        out.create(height, width, CV_32FC3);
        const int pairs[] = {0, 0, 1, 1, 2, 2};
        cv::mixChannels(&vectors, 1, &out, 1, pairs, 3);
    }

    // `read_colour`: false when `rgba` already holds the colour (the supersampled pass).
    // `single_sample_colour`: the colour was drawn in the pass that wrote the ids, without MSAA.
    void read_back(const RenderSettings& settings, bool with_normals, bool with_ids, bool read_colour,
                   bool single_sample_colour, Frame& frame) {
        if (read_colour) {
            rgba.create(height, width, CV_8UC4);
            gl.ReadBuffer(GL_COLOR_ATTACHMENT0 + kColourTarget);
            gl.ReadPixels(0, 0, width, height, GL_RGBA, GL_UNSIGNED_BYTE, rgba.data);
        }
        frame.rgb.create(height, width, CV_8UC3);
        frame.mask.create(height, width, CV_8UC1);
        const bool mask_from_ids = with_ids && single_sample_colour;
        if (mask_from_ids)
            cv::cvtColor(rgba, frame.rgb, cv::COLOR_RGBA2RGB);
        else
            split_colour_and_coverage(rgba, frame.rgb, frame.mask);
        if (settings.geometry) read_depth(frame.depth);
        else frame.depth.release();
        if (with_ids) {
            read_ids(frame.triangle_ids, frame.labels, mask_from_ids ? &frame.mask : nullptr);
        } else {
            frame.triangle_ids.release();
            frame.labels.release();
        }
        if (with_normals) read_vectors(kNormalTarget, frame.normals);
        else frame.normals.release();
        if (settings.barycentrics) read_vectors(kBarycentricTarget, frame.barycentrics);
        else frame.barycentrics.release();
    }

    void validate(const morph::Mesh& mesh, const Camera& camera, const RenderSettings& settings, const MeshExtras& extras) const {
        const morph::Intrinsics& k = camera.intrinsics;
        if (k.width <= 0 || k.height <= 0 || k.width > 16384 || k.height > 16384)
            throw core::Error("render: image size " + std::to_string(k.width) + "x" + std::to_string(k.height) + " is out of range");
        const Antialiasing& aa = settings.antialiasing;
        const auto [fewest, most] = antialiasing_sample_range(aa.method);
        if (aa.samples < fewest || aa.samples > most)
            throw core::Error("render: " + std::string(antialiasing_name(aa.method)) + " anti-aliasing with " + std::to_string(aa.samples) +
                              " samples is out of range [" + std::to_string(fewest) + ", " + std::to_string(most) + "]");
        if (static_cast<long>(aa.supersampling_factor()) * std::max(k.width, k.height) > max_texture_size)
            throw core::Error("render: a " + std::to_string(k.width) + "x" + std::to_string(k.height) + " image supersampled " +
                        std::to_string(aa.supersampling_factor()) + "x exceeds the largest render target (" +
                        std::to_string(max_texture_size) + ")");
        if (!(k.fx > 0) || !(k.fy > 0)) throw core::Error("render: camera focal lengths must be positive");
        if (mesh.num_vertices() == 0 || mesh.triangles.empty()) throw core::Error("render: the mesh is empty");
        if (mesh.colours.cols() != 0 && mesh.colours.cols() != mesh.num_vertices())
            throw core::Error("render: mesh has " + std::to_string(mesh.colours.cols()) + " colours for " +
                        std::to_string(mesh.num_vertices()) + " vertices");
        if (!extras.vertex_labels.empty() && extras.vertex_labels.size() != static_cast<std::size_t>(mesh.num_vertices()))
            throw core::Error("render: " + std::to_string(extras.vertex_labels.size()) + " vertex labels for " +
                        std::to_string(mesh.num_vertices()) + " vertices");
        if (extras.texture != nullptr) {
            if (extras.texture->type() != CV_8UC3 || extras.texture->empty())
                throw core::Error("render: the texture must be a non-empty 8-bit RGB image");
            if (mesh.uv.cols() != mesh.num_vertices()) throw core::Error("render: a texture needs per-vertex uv coordinates");
        }
        // Triangle indices are checked when the provoking topology is built (once per triangle list).
    }
};

Renderer::Renderer(const RendererOptions& options) : impl_(std::make_unique<Impl>(options)) {}
Renderer::~Renderer() = default;
Renderer::Renderer(Renderer&&) noexcept = default;
Renderer& Renderer::operator=(Renderer&&) noexcept = default;

void Renderer::render(const morph::Mesh& mesh, const Camera& camera, const RenderSettings& settings, Frame& frame,
                      const MeshExtras& extras) {
    impl_->render(mesh, camera, settings, frame, extras);
}

Frame Renderer::render(const morph::Mesh& mesh, const Camera& camera, const RenderSettings& settings, const MeshExtras& extras) {
    Frame frame;
    impl_->render(mesh, camera, settings, frame, extras);
    return frame;
}

void Renderer::detach() {
    if (impl_) impl_->context->release();
}

std::string Renderer::backend() const { return impl_->context->backend_name(); }
std::string Renderer::renderer_string() const { return impl_->renderer_string; }

}  // namespace facesynth::render
