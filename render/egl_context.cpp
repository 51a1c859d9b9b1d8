#include "render/gl_context.h"

#include "core/error.h"

#include <EGL/egl.h>
#include <EGL/eglext.h>

#include <cstring>
#include <vector>

namespace facesynth::render::detail {
namespace {

std::string egl_error_text(const char* what) {
    char code[32];
    std::snprintf(code, sizeof code, "0x%04x", static_cast<unsigned>(eglGetError()));
    return std::string("EGL: ") + what + " failed (error " + code + ")";
}

bool has_extension(const char* extensions, const char* name) {
    if (extensions == nullptr) return false;
    const std::size_t n = std::strlen(name);
    for (const char* p = extensions; (p = std::strstr(p, name)) != nullptr; p += n)
        if ((p == extensions || p[-1] == ' ') && (p[n] == ' ' || p[n] == '\0')) return true;
    return false;
}

enum class DeviceKind { kHardware, kSoftware };

// An initialised display on the first EGL device of that kind (a GPU from e.g. NVIDIA's EGL, or
// Mesa's software rasteriser listed as a device), or EGL_NO_DISPLAY when there is none.
EGLDisplay device_display(DeviceKind kind) {
    const char* client = eglQueryString(EGL_NO_DISPLAY, EGL_EXTENSIONS);
    if (!has_extension(client, "EGL_EXT_platform_device") || !has_extension(client, "EGL_EXT_device_enumeration"))
        return EGL_NO_DISPLAY;
    auto query_devices = reinterpret_cast<PFNEGLQUERYDEVICESEXTPROC>(eglGetProcAddress("eglQueryDevicesEXT"));
    auto query_device_string = reinterpret_cast<PFNEGLQUERYDEVICESTRINGEXTPROC>(eglGetProcAddress("eglQueryDeviceStringEXT"));
    auto get_platform_display = reinterpret_cast<PFNEGLGETPLATFORMDISPLAYEXTPROC>(eglGetProcAddress("eglGetPlatformDisplayEXT"));
    if (!query_devices || !query_device_string || !get_platform_display) return EGL_NO_DISPLAY;
    EGLint count = 0;
    if (!query_devices(0, nullptr, &count) || count <= 0) return EGL_NO_DISPLAY;
    std::vector<EGLDeviceEXT> devices(static_cast<std::size_t>(count));
    if (!query_devices(count, devices.data(), &count)) return EGL_NO_DISPLAY;
    for (EGLint i = 0; i < count; ++i) {
        const char* extensions = query_device_string(devices[static_cast<std::size_t>(i)], EGL_EXTENSIONS);
        if (has_extension(extensions, "EGL_MESA_device_software") != (kind == DeviceKind::kSoftware)) continue;
        EGLDisplay display = get_platform_display(EGL_PLATFORM_DEVICE_EXT, devices[static_cast<std::size_t>(i)], nullptr);
        if (display == EGL_NO_DISPLAY) continue;
        EGLint major = 0, minor = 0;
        if (eglInitialize(display, &major, &minor)) return display;
    }
    return EGL_NO_DISPLAY;
}


class EglContext final : public GlContext {
public:
    EglContext(bool allow_device, bool software_device) {
        if (allow_device && try_device(DeviceKind::kHardware, "egl-device")) return;
        // Mesa's software device is a display of its own, separate from the surfaceless one (each
        // display has its own llvmpipe screen and rasteriser), with the same driver.
        if (software_device && try_device(DeviceKind::kSoftware, "egl-software-device")) return;
        const char* client = eglQueryString(EGL_NO_DISPLAY, EGL_EXTENSIONS);
        if (!has_extension(client, "EGL_MESA_platform_surfaceless"))
            throw core::Error("EGL: the surfaceless platform (EGL_MESA_platform_surfaceless) is not available");
        auto get_platform_display = reinterpret_cast<PFNEGLGETPLATFORMDISPLAYEXTPROC>(eglGetProcAddress("eglGetPlatformDisplayEXT"));
        if (!get_platform_display) throw core::Error("EGL: eglGetPlatformDisplayEXT is not available");
        display_ = get_platform_display(EGL_PLATFORM_SURFACELESS_MESA, EGL_DEFAULT_DISPLAY, nullptr);
        if (display_ == EGL_NO_DISPLAY) throw core::Error(egl_error_text("eglGetPlatformDisplayEXT(surfaceless)"));
        EGLint major = 0, minor = 0;
        if (!eglInitialize(display_, &major, &minor)) throw core::Error(egl_error_text("eglInitialize(surfaceless)"));
        name_ = "egl-surfaceless";
        if (!try_create_context()) {
            const std::string message = egl_error_text("creating an OpenGL 3.3 core context");
            eglTerminate(display_);
            throw core::Error(message);
        }
    }

    ~EglContext() override {
        if (eglGetCurrentContext() == context_) eglMakeCurrent(display_, EGL_NO_SURFACE, EGL_NO_SURFACE, EGL_NO_CONTEXT);
        if (last_bound_context() == this) last_bound_context() = nullptr;
        eglDestroyContext(display_, context_);
        // eglTerminate would also end other renderers' contexts on this display (displays are
        // shared per device within a process), so the display stays initialised.
    }
    EglContext(const EglContext&) = delete;
    EglContext& operator=(const EglContext&) = delete;

    void make_current() override {
        if (last_bound_context() == this && eglGetCurrentContext() == context_) return;
        // EGL may believe this context is still bound after OSMesa took the thread: unbind first.
        if (eglGetCurrentContext() == context_) eglMakeCurrent(display_, EGL_NO_SURFACE, EGL_NO_SURFACE, EGL_NO_CONTEXT);
        if (!eglMakeCurrent(display_, EGL_NO_SURFACE, EGL_NO_SURFACE, context_))
            throw core::Error(egl_error_text("eglMakeCurrent"));
        last_bound_context() = this;
    }
    void release() override {
        if (eglGetCurrentContext() == context_) eglMakeCurrent(display_, EGL_NO_SURFACE, EGL_NO_SURFACE, EGL_NO_CONTEXT);
        if (last_bound_context() == this) last_bound_context() = nullptr;
    }
    void* get_proc_address(const char* name) const override {
        return reinterpret_cast<void*>(eglGetProcAddress(name));
    }
    std::string backend_name() const override { return name_; }

private:
    bool try_device(DeviceKind kind, const char* name) {
        display_ = device_display(kind);
        if (display_ == EGL_NO_DISPLAY) return false;
        name_ = name;
        if (try_create_context()) return true;
        // Not terminated: other renderers of this process may have contexts on the same display.
        display_ = EGL_NO_DISPLAY;
        return false;
    }

    bool try_create_context() {
        if (!eglBindAPI(EGL_OPENGL_API)) return false;
        const EGLint config_attributes[] = {EGL_RENDERABLE_TYPE, EGL_OPENGL_BIT, EGL_SURFACE_TYPE, 0, EGL_NONE};
        EGLConfig config = nullptr;
        EGLint num_configs = 0;
        if (!eglChooseConfig(display_, config_attributes, &config, 1, &num_configs) || num_configs < 1) {
            const EGLint any_surface[] = {EGL_RENDERABLE_TYPE, EGL_OPENGL_BIT, EGL_NONE};
            if (!eglChooseConfig(display_, any_surface, &config, 1, &num_configs) || num_configs < 1) return false;
        }
        const EGLint context_attributes[] = {EGL_CONTEXT_MAJOR_VERSION, 3, EGL_CONTEXT_MINOR_VERSION, 3,
                                             EGL_CONTEXT_OPENGL_PROFILE_MASK, EGL_CONTEXT_OPENGL_CORE_PROFILE_BIT, EGL_NONE};
        context_ = eglCreateContext(display_, config, EGL_NO_CONTEXT, context_attributes);
        if (context_ == EGL_NO_CONTEXT) return false;
        if (!eglMakeCurrent(display_, EGL_NO_SURFACE, EGL_NO_SURFACE, context_)) {
            eglDestroyContext(display_, context_);
            context_ = EGL_NO_CONTEXT;
            return false;
        }
        last_bound_context() = this;
        return true;
    }

    EGLDisplay display_ = EGL_NO_DISPLAY;
    EGLContext context_ = EGL_NO_CONTEXT;
    std::string name_;
};

}  // namespace

const GlContext*& last_bound_context() {
    thread_local const GlContext* bound = nullptr;
    return bound;
}

std::unique_ptr<GlContext> create_egl_context(bool allow_device, bool software_device) {
    return std::make_unique<EglContext>(allow_device, software_device);
}

}  // namespace facesynth::render::detail
