/// @file gl_api.h
/// @brief The OpenGL 3.3 core functions the renderer uses, as a table of function pointers loaded
/// at run time (no libGL link, no loader library): types and constants come from the system's
/// GL/glcorearb.h.
#pragma once

#include <string>

#include <GL/glcorearb.h>

namespace aoscan {

// X(type, member, "glName") for every GL function the renderer calls.
#define AOSCAN_GL_FUNCTIONS(X)                                                              \
  X(PFNGLGETSTRINGPROC, GetString, "glGetString")                                           \
  X(PFNGLGETINTEGERVPROC, GetIntegerv, "glGetIntegerv")                                     \
  X(PFNGLGETERRORPROC, GetError, "glGetError")                                              \
  X(PFNGLVIEWPORTPROC, Viewport, "glViewport")                                              \
  X(PFNGLCLEARCOLORPROC, ClearColor, "glClearColor")                                        \
  X(PFNGLCLEARDEPTHPROC, ClearDepth, "glClearDepth")                                        \
  X(PFNGLCLEARPROC, Clear, "glClear")                                                       \
  X(PFNGLCLEARBUFFERFVPROC, ClearBufferfv, "glClearBufferfv")                               \
  X(PFNGLENABLEPROC, Enable, "glEnable")                                                    \
  X(PFNGLDISABLEPROC, Disable, "glDisable")                                                 \
  X(PFNGLBLENDFUNCPROC, BlendFunc, "glBlendFunc")                                           \
  X(PFNGLDEPTHFUNCPROC, DepthFunc, "glDepthFunc")                                           \
  X(PFNGLDEPTHMASKPROC, DepthMask, "glDepthMask")                                           \
  X(PFNGLCOLORMASKPROC, ColorMask, "glColorMask")                                           \
  X(PFNGLPIXELSTOREIPROC, PixelStorei, "glPixelStorei")                                     \
  X(PFNGLREADPIXELSPROC, ReadPixels, "glReadPixels")                                        \
  X(PFNGLFINISHPROC, Finish, "glFinish")                                                    \
  X(PFNGLGENTEXTURESPROC, GenTextures, "glGenTextures")                                     \
  X(PFNGLDELETETEXTURESPROC, DeleteTextures, "glDeleteTextures")                            \
  X(PFNGLBINDTEXTUREPROC, BindTexture, "glBindTexture")                                     \
  X(PFNGLACTIVETEXTUREPROC, ActiveTexture, "glActiveTexture")                               \
  X(PFNGLTEXIMAGE2DPROC, TexImage2D, "glTexImage2D")                                        \
  X(PFNGLTEXSUBIMAGE2DPROC, TexSubImage2D, "glTexSubImage2D")                               \
  X(PFNGLTEXPARAMETERIPROC, TexParameteri, "glTexParameteri")                               \
  X(PFNGLCREATESHADERPROC, CreateShader, "glCreateShader")                                  \
  X(PFNGLSHADERSOURCEPROC, ShaderSource, "glShaderSource")                                  \
  X(PFNGLCOMPILESHADERPROC, CompileShader, "glCompileShader")                               \
  X(PFNGLGETSHADERIVPROC, GetShaderiv, "glGetShaderiv")                                     \
  X(PFNGLGETSHADERINFOLOGPROC, GetShaderInfoLog, "glGetShaderInfoLog")                      \
  X(PFNGLDELETESHADERPROC, DeleteShader, "glDeleteShader")                                  \
  X(PFNGLCREATEPROGRAMPROC, CreateProgram, "glCreateProgram")                               \
  X(PFNGLATTACHSHADERPROC, AttachShader, "glAttachShader")                                  \
  X(PFNGLLINKPROGRAMPROC, LinkProgram, "glLinkProgram")                                     \
  X(PFNGLGETPROGRAMIVPROC, GetProgramiv, "glGetProgramiv")                                  \
  X(PFNGLGETPROGRAMINFOLOGPROC, GetProgramInfoLog, "glGetProgramInfoLog")                   \
  X(PFNGLDELETEPROGRAMPROC, DeleteProgram, "glDeleteProgram")                               \
  X(PFNGLUSEPROGRAMPROC, UseProgram, "glUseProgram")                                        \
  X(PFNGLGETUNIFORMLOCATIONPROC, GetUniformLocation, "glGetUniformLocation")                \
  X(PFNGLUNIFORM1IPROC, Uniform1i, "glUniform1i")                                           \
  X(PFNGLUNIFORM1FPROC, Uniform1f, "glUniform1f")                                           \
  X(PFNGLUNIFORM2FPROC, Uniform2f, "glUniform2f")                                           \
  X(PFNGLUNIFORM3FPROC, Uniform3f, "glUniform3f")                                           \
  X(PFNGLUNIFORMMATRIX3FVPROC, UniformMatrix3fv, "glUniformMatrix3fv")                      \
  X(PFNGLUNIFORMMATRIX4FVPROC, UniformMatrix4fv, "glUniformMatrix4fv")                      \
  X(PFNGLGENVERTEXARRAYSPROC, GenVertexArrays, "glGenVertexArrays")                         \
  X(PFNGLBINDVERTEXARRAYPROC, BindVertexArray, "glBindVertexArray")                         \
  X(PFNGLDELETEVERTEXARRAYSPROC, DeleteVertexArrays, "glDeleteVertexArrays")                \
  X(PFNGLGENBUFFERSPROC, GenBuffers, "glGenBuffers")                                        \
  X(PFNGLBINDBUFFERPROC, BindBuffer, "glBindBuffer")                                        \
  X(PFNGLBUFFERDATAPROC, BufferData, "glBufferData")                                        \
  X(PFNGLDELETEBUFFERSPROC, DeleteBuffers, "glDeleteBuffers")                               \
  X(PFNGLVERTEXATTRIBPOINTERPROC, VertexAttribPointer, "glVertexAttribPointer")             \
  X(PFNGLENABLEVERTEXATTRIBARRAYPROC, EnableVertexAttribArray, "glEnableVertexAttribArray") \
  X(PFNGLDRAWARRAYSPROC, DrawArrays, "glDrawArrays")                                        \
  X(PFNGLGENFRAMEBUFFERSPROC, GenFramebuffers, "glGenFramebuffers")                         \
  X(PFNGLBINDFRAMEBUFFERPROC, BindFramebuffer, "glBindFramebuffer")                         \
  X(PFNGLDELETEFRAMEBUFFERSPROC, DeleteFramebuffers, "glDeleteFramebuffers")                \
  X(PFNGLFRAMEBUFFERTEXTURE2DPROC, FramebufferTexture2D, "glFramebufferTexture2D")          \
  X(PFNGLCHECKFRAMEBUFFERSTATUSPROC, CheckFramebufferStatus, "glCheckFramebufferStatus")    \
  X(PFNGLGENRENDERBUFFERSPROC, GenRenderbuffers, "glGenRenderbuffers")                      \
  X(PFNGLBINDRENDERBUFFERPROC, BindRenderbuffer, "glBindRenderbuffer")                      \
  X(PFNGLDELETERENDERBUFFERSPROC, DeleteRenderbuffers, "glDeleteRenderbuffers")             \
  X(PFNGLRENDERBUFFERSTORAGEPROC, RenderbufferStorage, "glRenderbufferStorage")             \
  X(PFNGLFRAMEBUFFERRENDERBUFFERPROC, FramebufferRenderbuffer, "glFramebufferRenderbuffer")

/// Looks a GL function up by name in the current context (e.g. glfwGetProcAddress).
using GlProcLoader = void* (*)(const char* name);

/// The function table. Valid for the context that was current when load() ran (and, on Mesa/GLX,
/// for every context of the process).
struct GlApi {
#define AOSCAN_GL_MEMBER(type, member, name) type member = nullptr;
  AOSCAN_GL_FUNCTIONS(AOSCAN_GL_MEMBER)
#undef AOSCAN_GL_MEMBER

  /// Loads every function; false with `error` naming the first missing one.
  bool load(GlProcLoader loader, std::string& error);
  /// "major.minor" of the current context, e.g. 3.3 → 33; 0 when unknown.
  int version() const;
};

}  // namespace aoscan
