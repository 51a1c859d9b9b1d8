#include "render/gl_context.h"

#include "core/error.h"

#include <GL/osmesa.h>
#include <dlfcn.h>

#include <array>
#include <cstdlib>
#include <memory>
#include <string>
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

// libOSMesa is opened when an OSMesa context is made rather than linked: it links LLVM, whose
// loading cost every start of the CLI and of every test program about a tenth of a second, though
// OSMesa is only the fallback when EGL cannot start. RTLD_NODELETE: Mesa and LLVM stay loaded after
// the last context, as a linked library would.
class OsmesaLibrary {
public:
    OsmesaLibrary() {
        for (const char* name : {"libOSMesa.so.8", "libOSMesa.so"}) {
            handle_.reset(::dlopen(name, RTLD_NOW | RTLD_LOCAL | RTLD_NODELETE));
            if (handle_) break;
        }
        if (!handle_) {
            const char* why = ::dlerror();
            throw core::Error(std::string("OSMesa: cannot load libOSMesa.so.8") + (why != nullptr ? std::string(": ") + why : std::string()));
        }
        create_context = symbol<decltype(&OSMesaCreateContextAttribs)>("OSMesaCreateContextAttribs");
        destroy_context = symbol<decltype(&OSMesaDestroyContext)>("OSMesaDestroyContext");
        make_current = symbol<decltype(&OSMesaMakeCurrent)>("OSMesaMakeCurrent");
        current_context = symbol<decltype(&OSMesaGetCurrentContext)>("OSMesaGetCurrentContext");
        proc_address = symbol<decltype(&OSMesaGetProcAddress)>("OSMesaGetProcAddress");
    }

    decltype(&OSMesaCreateContextAttribs) create_context = nullptr;
    decltype(&OSMesaDestroyContext) destroy_context = nullptr;
    decltype(&OSMesaMakeCurrent) make_current = nullptr;
    decltype(&OSMesaGetCurrentContext) current_context = nullptr;
    decltype(&OSMesaGetProcAddress) proc_address = nullptr;

private:
    struct Closer {
        void operator()(void* handle) const { ::dlclose(handle); }
    };

    template <typename Function>
    Function symbol(const char* name) const {
        void* address = ::dlsym(handle_.get(), name);
        if (address == nullptr) throw core::Error(std::string("OSMesa: libOSMesa has no ") + name);
        return reinterpret_cast<Function>(address);  // NOLINT(cppcoreguidelines-pro-type-reinterpret-cast): dlsym's contract
    }

    std::unique_ptr<void, Closer> handle_;
};

class OsmesaContext final : public GlContext {
public:
    OsmesaContext() {
        check_gallium_driver();
        const int attributes[] = {OSMESA_FORMAT, OSMESA_RGBA, OSMESA_DEPTH_BITS, 0, OSMESA_STENCIL_BITS, 0,
                                  OSMESA_ACCUM_BITS, 0, OSMESA_PROFILE, OSMESA_CORE_PROFILE,
                                  OSMESA_CONTEXT_MAJOR_VERSION, 3, OSMESA_CONTEXT_MINOR_VERSION, 3, 0};
        context_ = library_.create_context(attributes, nullptr);
        if (context_ == nullptr) throw core::Error("OSMesa: creating an OpenGL 3.3 core context failed");
        make_current();
    }
    ~OsmesaContext() override {
        if (last_bound_context() == this) last_bound_context() = nullptr;
        library_.destroy_context(context_);
    }
    OsmesaContext(const OsmesaContext&) = delete;
    OsmesaContext& operator=(const OsmesaContext&) = delete;

    void make_current() override {
        if (last_bound_context() == this && library_.current_context() == context_) return;
        // Rendering goes to framebuffer objects; the default framebuffer is a 1x1 placeholder.
        if (!library_.make_current(context_, placeholder_.data(), GL_UNSIGNED_BYTE, 1, 1))
            throw core::Error("OSMesa: OSMesaMakeCurrent failed");
        last_bound_context() = this;
    }
    void release() override {
        // OSMesa has no unbind (OSMesaMakeCurrent(NULL, ...) crashes in Mesa 22) and does not tie a
        // context to one thread; forgetting the binding makes the next make_current rebind.
        if (last_bound_context() == this) last_bound_context() = nullptr;
    }
    void* get_proc_address(const char* name) const override {
        return reinterpret_cast<void*>(library_.proc_address(name));
    }
    std::string backend_name() const override { return "osmesa"; }

private:
    OsmesaLibrary library_;
    OSMesaContext context_ = nullptr;
    std::array<unsigned char, 4> placeholder_{};
};

}  // namespace

std::unique_ptr<GlContext> create_osmesa_context() { return std::make_unique<OsmesaContext>(); }

}  // namespace facesynth::render::detail
