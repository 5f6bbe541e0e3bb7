#pragma once
// The OpenGL 4.5 core functions the noise programs use, loaded through the context's own
// GetProcAddress (OSMesa or EGL). Nothing links libGL: the process never mixes two GL vendors'
// exported symbols, and it runs where no GL library is installed (CPU backend only).
#include <GL/glcorearb.h>

#include <string>

namespace textond::render::gl {

#define TEXTOND_GL_FUNCTIONS(X)                                                                    \
    X(PFNGLGETSTRINGPROC, GetString)                                                               \
    X(PFNGLGETERRORPROC, GetError)                                                                 \
    X(PFNGLGETINTEGERVPROC, GetIntegerv)                                                           \
    X(PFNGLCREATESHADERPROC, CreateShader)                                                         \
    X(PFNGLSHADERSOURCEPROC, ShaderSource)                                                         \
    X(PFNGLCOMPILESHADERPROC, CompileShader)                                                       \
    X(PFNGLGETSHADERIVPROC, GetShaderiv)                                                           \
    X(PFNGLGETSHADERINFOLOGPROC, GetShaderInfoLog)                                                 \
    X(PFNGLDELETESHADERPROC, DeleteShader)                                                         \
    X(PFNGLCREATEPROGRAMPROC, CreateProgram)                                                       \
    X(PFNGLATTACHSHADERPROC, AttachShader)                                                         \
    X(PFNGLLINKPROGRAMPROC, LinkProgram)                                                           \
    X(PFNGLGETPROGRAMIVPROC, GetProgramiv)                                                         \
    X(PFNGLGETPROGRAMINFOLOGPROC, GetProgramInfoLog)                                               \
    X(PFNGLDELETEPROGRAMPROC, DeleteProgram)                                                       \
    X(PFNGLUSEPROGRAMPROC, UseProgram)                                                             \
    X(PFNGLGETUNIFORMLOCATIONPROC, GetUniformLocation)                                             \
    X(PFNGLUNIFORM1IPROC, Uniform1i)                                                               \
    X(PFNGLUNIFORM2IPROC, Uniform2i)                                                               \
    X(PFNGLUNIFORM2UIPROC, Uniform2ui)                                                             \
    X(PFNGLUNIFORM1FPROC, Uniform1f)                                                               \
    X(PFNGLUNIFORM3FPROC, Uniform3f)                                                               \
    X(PFNGLUNIFORM1UIVPROC, Uniform1uiv)                                                           \
    X(PFNGLUNIFORM1FVPROC, Uniform1fv)                                                             \
    X(PFNGLUNIFORMMATRIX3FVPROC, UniformMatrix3fv)                                                 \
    X(PFNGLGENTEXTURESPROC, GenTextures)                                                           \
    X(PFNGLDELETETEXTURESPROC, DeleteTextures)                                                     \
    X(PFNGLBINDTEXTUREPROC, BindTexture)                                                           \
    X(PFNGLACTIVETEXTUREPROC, ActiveTexture)                                                       \
    X(PFNGLTEXIMAGE2DPROC, TexImage2D)                                                             \
    X(PFNGLTEXPARAMETERIPROC, TexParameteri)                                                       \
    X(PFNGLPIXELSTOREIPROC, PixelStorei)                                                           \
    X(PFNGLGENFRAMEBUFFERSPROC, GenFramebuffers)                                                   \
    X(PFNGLDELETEFRAMEBUFFERSPROC, DeleteFramebuffers)                                             \
    X(PFNGLBINDFRAMEBUFFERPROC, BindFramebuffer)                                                   \
    X(PFNGLFRAMEBUFFERTEXTURE2DPROC, FramebufferTexture2D)                                         \
    X(PFNGLCHECKFRAMEBUFFERSTATUSPROC, CheckFramebufferStatus)                                     \
    X(PFNGLGENVERTEXARRAYSPROC, GenVertexArrays)                                                   \
    X(PFNGLDELETEVERTEXARRAYSPROC, DeleteVertexArrays)                                             \
    X(PFNGLBINDVERTEXARRAYPROC, BindVertexArray)                                                   \
    X(PFNGLDRAWARRAYSPROC, DrawArrays)                                                             \
    X(PFNGLVIEWPORTPROC, Viewport)                                                                 \
    X(PFNGLREADPIXELSPROC, ReadPixels)                                                             \
    X(PFNGLFINISHPROC, Finish)                                                                     \
    X(PFNGLDISABLEPROC, Disable)                                                                   \
    X(PFNGLGENBUFFERSPROC, GenBuffers)                                                             \
    X(PFNGLDELETEBUFFERSPROC, DeleteBuffers)                                                       \
    X(PFNGLBINDBUFFERPROC, BindBuffer)                                                             \
    X(PFNGLBUFFERDATAPROC, BufferData)                                                             \
    X(PFNGLBINDBUFFERBASEPROC, BindBufferBase)                                                     \
    X(PFNGLGETBUFFERSUBDATAPROC, GetBufferSubData)                                                 \
    X(PFNGLDISPATCHCOMPUTEPROC, DispatchCompute)                                                   \
    X(PFNGLMEMORYBARRIERPROC, MemoryBarrier)                                                       \
    X(PFNGLENABLEPROC, Enable)                                                                     \
    X(PFNGLCLEARPROC, Clear)                                                                       \
    X(PFNGLCLEARCOLORPROC, ClearColor)                                                             \
    X(PFNGLVERTEXATTRIBPOINTERPROC, VertexAttribPointer)                                           \
    X(PFNGLENABLEVERTEXATTRIBARRAYPROC, EnableVertexAttribArray)                                   \
    X(PFNGLDRAWELEMENTSPROC, DrawElements)                                                         \
    X(PFNGLGENRENDERBUFFERSPROC, GenRenderbuffers)                                                 \
    X(PFNGLDELETERENDERBUFFERSPROC, DeleteRenderbuffers)                                           \
    X(PFNGLBINDRENDERBUFFERPROC, BindRenderbuffer)                                                 \
    X(PFNGLRENDERBUFFERSTORAGEPROC, RenderbufferStorage)                                           \
    X(PFNGLFRAMEBUFFERRENDERBUFFERPROC, FramebufferRenderbuffer)                                   \
    X(PFNGLUNIFORMMATRIX4FVPROC, UniformMatrix4fv)                                                 \
    X(PFNGLUNIFORM2FPROC, Uniform2f)                                                               \
    X(PFNGLTEXIMAGE3DPROC, TexImage3D)                                                             \
    X(PFNGLBINDIMAGETEXTUREPROC, BindImageTexture)                                                 \
    X(PFNGLBUFFERSUBDATAPROC, BufferSubData)                                                       \
    X(PFNGLGENQUERIESPROC, GenQueries)                                                             \
    X(PFNGLDELETEQUERIESPROC, DeleteQueries)                                                       \
    X(PFNGLBEGINQUERYPROC, BeginQuery)                                                             \
    X(PFNGLENDQUERYPROC, EndQuery)                                                                 \
    X(PFNGLGETQUERYOBJECTUI64VPROC, GetQueryObjectui64v)                                           \
    X(PFNGLBUFFERSTORAGEPROC, BufferStorage)                                                       \
    X(PFNGLMAPBUFFERRANGEPROC, MapBufferRange)                                                     \
    X(PFNGLUNMAPBUFFERPROC, UnmapBuffer)                                                           \
    X(PFNGLCOPYBUFFERSUBDATAPROC, CopyBufferSubData)                                               \
    X(PFNGLFENCESYNCPROC, FenceSync)                                                               \
    X(PFNGLCLIENTWAITSYNCPROC, ClientWaitSync)                                                     \
    X(PFNGLDELETESYNCPROC, DeleteSync)

struct GlApi {
#define TEXTOND_GL_DECLARE(type, name) type name = nullptr;
    TEXTOND_GL_FUNCTIONS(TEXTOND_GL_DECLARE)
#undef TEXTOND_GL_DECLARE

    // Fills every pointer from `get`; returns the name of the first one missing, or "".
    using Loader = void* (*)(const char* name, void* user);
    std::string load(Loader get, void* user);
};

} // namespace textond::render::gl
