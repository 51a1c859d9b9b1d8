#pragma once
// Internal: an offscreen OpenGL 3.3 core context from one backend. Created once, reused for every
// render on the thread that uses it; destroyed with the owner.
#include <memory>
#include <string>

namespace facesynth::render::detail {

class GlContext {
public:
    virtual ~GlContext() = default;
    // Binds the context to the calling thread if it is not already.
    virtual void make_current() = 0;
    // Unbinds the context from the calling thread (if bound there) so another thread may bind it.
    virtual void release() = 0;
    [[nodiscard]] virtual void* get_proc_address(const char* name) const = 0;
    // "egl-device", "egl-surfaceless", "egl-software-device" or "osmesa".
    [[nodiscard]] virtual std::string backend_name() const = 0;
};

// EGL: a GPU device from the EGL device platform when a driver offers one (and `allow_device`),
// else Mesa's software rasteriser on the surfaceless platform, or on its software device when
// `software_device` and Mesa lists one (a second display, so a second llvmpipe screen). Throws
// core::Error saying what failed.
[[nodiscard]] std::unique_ptr<GlContext> create_egl_context(bool allow_device, bool software_device);
// Mesa's classic off-screen path. Throws core::Error saying what failed.
[[nodiscard]] std::unique_ptr<GlContext> create_osmesa_context();

// EGL and OSMesa share Mesa's GL dispatch (one current context per thread), but neither knows when
// the other bound a context. Each backend records here which context it bound last on this thread
// and rebinds when another was bound since.
[[nodiscard]] const GlContext*& last_bound_context();

}  // namespace facesynth::render::detail
