#pragma once
// Internal: the OpenGL 3.3 core entry points the renderer uses, loaded through the backend's
// GetProcAddress (eglGetProcAddress / OSMesaGetProcAddress) into a table. Nothing links GL symbols
// directly, so libEGL (glvnd) and libOSMesa can live in one process without their dispatch
// tables fighting.
#include <GL/glcorearb.h>

#include <functional>
#include <string>

namespace facesynth::render::detail {

#define FACESYNTH_GL_FUNCTIONS(X)                                       \
    X(PFNGLGETSTRINGPROC, GetString)                                    \
    X(PFNGLGETERRORPROC, GetError)                                      \
    X(PFNGLGETINTEGERVPROC, GetIntegerv)                                \
    X(PFNGLENABLEPROC, Enable)                                          \
    X(PFNGLDISABLEPROC, Disable)                                        \
    X(PFNGLCULLFACEPROC, CullFace)                                      \
    X(PFNGLFRONTFACEPROC, FrontFace)                                    \
    X(PFNGLDEPTHFUNCPROC, DepthFunc)                                    \
    X(PFNGLVIEWPORTPROC, Viewport)                                      \
    X(PFNGLSCISSORPROC, Scissor)                                        \
    X(PFNGLCLEARBUFFERFVPROC, ClearBufferfv)                            \
    X(PFNGLCLEARBUFFERUIVPROC, ClearBufferuiv)                          \
    X(PFNGLDRAWELEMENTSPROC, DrawElements)                              \
    X(PFNGLDRAWARRAYSPROC, DrawArrays)                                  \
    X(PFNGLREADPIXELSPROC, ReadPixels)                                  \
    X(PFNGLPIXELSTOREIPROC, PixelStorei)                                \
    X(PFNGLFINISHPROC, Finish)                                          \
    X(PFNGLPROVOKINGVERTEXPROC, ProvokingVertex)                        \
    X(PFNGLGENBUFFERSPROC, GenBuffers)                                  \
    X(PFNGLDELETEBUFFERSPROC, DeleteBuffers)                            \
    X(PFNGLBINDBUFFERPROC, BindBuffer)                                  \
    X(PFNGLBUFFERDATAPROC, BufferData)                                  \
    X(PFNGLBUFFERSUBDATAPROC, BufferSubData)                            \
    X(PFNGLGENVERTEXARRAYSPROC, GenVertexArrays)                        \
    X(PFNGLDELETEVERTEXARRAYSPROC, DeleteVertexArrays)                  \
    X(PFNGLBINDVERTEXARRAYPROC, BindVertexArray)                        \
    X(PFNGLVERTEXATTRIBPOINTERPROC, VertexAttribPointer)                \
    X(PFNGLVERTEXATTRIBIPOINTERPROC, VertexAttribIPointer)              \
    X(PFNGLENABLEVERTEXATTRIBARRAYPROC, EnableVertexAttribArray)        \
    X(PFNGLDISABLEVERTEXATTRIBARRAYPROC, DisableVertexAttribArray)      \
    X(PFNGLVERTEXATTRIB3FPROC, VertexAttrib3f)                          \
    X(PFNGLVERTEXATTRIB2FPROC, VertexAttrib2f)                          \
    X(PFNGLVERTEXATTRIBI1UIPROC, VertexAttribI1ui)                      \
    X(PFNGLCREATESHADERPROC, CreateShader)                              \
    X(PFNGLDELETESHADERPROC, DeleteShader)                              \
    X(PFNGLSHADERSOURCEPROC, ShaderSource)                              \
    X(PFNGLCOMPILESHADERPROC, CompileShader)                            \
    X(PFNGLGETSHADERIVPROC, GetShaderiv)                                \
    X(PFNGLGETSHADERINFOLOGPROC, GetShaderInfoLog)                      \
    X(PFNGLCREATEPROGRAMPROC, CreateProgram)                            \
    X(PFNGLDELETEPROGRAMPROC, DeleteProgram)                            \
    X(PFNGLATTACHSHADERPROC, AttachShader)                              \
    X(PFNGLLINKPROGRAMPROC, LinkProgram)                                \
    X(PFNGLGETPROGRAMIVPROC, GetProgramiv)                              \
    X(PFNGLGETPROGRAMINFOLOGPROC, GetProgramInfoLog)                    \
    X(PFNGLUSEPROGRAMPROC, UseProgram)                                  \
    X(PFNGLGETUNIFORMLOCATIONPROC, GetUniformLocation)                  \
    X(PFNGLUNIFORM1IPROC, Uniform1i)                                    \
    X(PFNGLUNIFORM1FPROC, Uniform1f)                                    \
    X(PFNGLUNIFORM1FVPROC, Uniform1fv)                                  \
    X(PFNGLUNIFORM3FVPROC, Uniform3fv)                                  \
    X(PFNGLUNIFORM4FVPROC, Uniform4fv)                                  \
    X(PFNGLUNIFORMMATRIX3FVPROC, UniformMatrix3fv)                      \
    X(PFNGLUNIFORMMATRIX4FVPROC, UniformMatrix4fv)                      \
    X(PFNGLGENFRAMEBUFFERSPROC, GenFramebuffers)                        \
    X(PFNGLDELETEFRAMEBUFFERSPROC, DeleteFramebuffers)                  \
    X(PFNGLBINDFRAMEBUFFERPROC, BindFramebuffer)                        \
    X(PFNGLFRAMEBUFFERRENDERBUFFERPROC, FramebufferRenderbuffer)        \
    X(PFNGLCHECKFRAMEBUFFERSTATUSPROC, CheckFramebufferStatus)          \
    X(PFNGLGENRENDERBUFFERSPROC, GenRenderbuffers)                      \
    X(PFNGLDELETERENDERBUFFERSPROC, DeleteRenderbuffers)                \
    X(PFNGLBINDRENDERBUFFERPROC, BindRenderbuffer)                      \
    X(PFNGLRENDERBUFFERSTORAGEPROC, RenderbufferStorage)                \
    X(PFNGLRENDERBUFFERSTORAGEMULTISAMPLEPROC, RenderbufferStorageMultisample) \
    X(PFNGLDRAWBUFFERSPROC, DrawBuffers)                                \
    X(PFNGLREADBUFFERPROC, ReadBuffer)                                  \
    X(PFNGLBLITFRAMEBUFFERPROC, BlitFramebuffer)                        \
    X(PFNGLGENTEXTURESPROC, GenTextures)                                \
    X(PFNGLDELETETEXTURESPROC, DeleteTextures)                          \
    X(PFNGLBINDTEXTUREPROC, BindTexture)                                \
    X(PFNGLACTIVETEXTUREPROC, ActiveTexture)                            \
    X(PFNGLTEXIMAGE2DPROC, TexImage2D)                                  \
    X(PFNGLTEXSUBIMAGE2DPROC, TexSubImage2D)                            \
    X(PFNGLTEXIMAGE3DPROC, TexImage3D)                                  \
    X(PFNGLFRAMEBUFFERTEXTURELAYERPROC, FramebufferTextureLayer)        \
    X(PFNGLTEXPARAMETERIPROC, TexParameteri)                            \
    X(PFNGLFRAMEBUFFERTEXTURE2DPROC, FramebufferTexture2D)

struct GlFunctions {
#define FACESYNTH_GL_MEMBER(type, name) type name = nullptr;
    FACESYNTH_GL_FUNCTIONS(FACESYNTH_GL_MEMBER)
#undef FACESYNTH_GL_MEMBER

    // Resolves every entry point; throws core::Error naming the first one missing.
    void load(const std::function<void*(const char*)>& get_proc_address, const std::string& backend);
};

}  // namespace facesynth::render::detail
