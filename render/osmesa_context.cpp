#include "render/gl_context.h"

#include "core/error.h"

#include <GL/osmesa.h>

#include <array>
#include <cstdlib>
#include <string_view>

namespace facesynth::render::detail {
namespace {

// Mesa 22's OSMesa crashes inside OSMesaCreateContextAttribs when GALLIUM_DRIVER names a driver
// it does not contain, so that case is refused before calling it.
void check_gallium_driver() {
    const char* driver = std::getenv("GALLIUM_DRIVER");
    if (driver == nullptr || *driver == '\0') return;
    const std::string_view name(driver);
    if (name != "llvmpipe" && name != "softpipe")
        throw core::Error("OSMesa: GALLIUM_DRIVER='" + std::string(name) +
                    "' is not a software rasteriser OSMesa provides (llvmpipe or softpipe); unset it or choose one");
}

class OsmesaContext final : public GlContext {
public:
    OsmesaContext() {
        check_gallium_driver();
        const int attributes[] = {OSMESA_FORMAT, OSMESA_RGBA, OSMESA_DEPTH_BITS, 0, OSMESA_STENCIL_BITS, 0,
                                  OSMESA_ACCUM_BITS, 0, OSMESA_PROFILE, OSMESA_CORE_PROFILE,
                                  OSMESA_CONTEXT_MAJOR_VERSION, 3, OSMESA_CONTEXT_MINOR_VERSION, 3, 0};
        context_ = OSMesaCreateContextAttribs(attributes, nullptr);
        if (context_ == nullptr) throw core::Error("OSMesa: creating an OpenGL 3.3 core context failed");
        make_current();
    }
    ~OsmesaContext() override {
        if (last_bound_context() == this) last_bound_context() = nullptr;
        OSMesaDestroyContext(context_);
    }
    OsmesaContext(const OsmesaContext&) = delete;
    OsmesaContext& operator=(const OsmesaContext&) = delete;

    void make_current() override {
        if (last_bound_context() == this && OSMesaGetCurrentContext() == context_) return;
        // Rendering goes to framebuffer objects; the default framebuffer is a 1x1 placeholder.
        if (!OSMesaMakeCurrent(context_, placeholder_.data(), GL_UNSIGNED_BYTE, 1, 1))
            throw core::Error("OSMesa: OSMesaMakeCurrent failed");
        last_bound_context() = this;
    }
    void release() override {
        // OSMesa has no unbind (OSMesaMakeCurrent(NULL, ...) crashes in Mesa 22) and does not tie a
        // context to one thread; forgetting the binding makes the next make_current rebind.
        if (last_bound_context() == this) last_bound_context() = nullptr;
    }
    void* get_proc_address(const char* name) const override {
        return reinterpret_cast<void*>(OSMesaGetProcAddress(name));
    }
    std::string backend_name() const override { return "osmesa"; }

private:
    OSMesaContext context_ = nullptr;
    std::array<unsigned char, 4> placeholder_{};
};

}  // namespace

std::unique_ptr<GlContext> create_osmesa_context() { return std::make_unique<OsmesaContext>(); }

}  // namespace facesynth::render::detail
