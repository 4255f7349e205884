/// @file gl_api.cpp
/// @brief Loading the GL function table.
#include "render/gl_api.h"

namespace aoscan {

bool GlApi::load(GlProcLoader loader, std::string& error) {
#define AOSCAN_GL_LOAD(type, member, name)                          \
  member = reinterpret_cast<type>(loader(name));                    \
  if (!member) {                                                    \
    error = std::string("OpenGL function ") + name + " is missing"; \
    return false;                                                   \
  }
  AOSCAN_GL_FUNCTIONS(AOSCAN_GL_LOAD)
#undef AOSCAN_GL_LOAD
  return true;
}

int GlApi::version() const {
  if (!GetIntegerv) return 0;
  GLint major = 0;
  GLint minor = 0;
  GetIntegerv(GL_MAJOR_VERSION, &major);
  GetIntegerv(GL_MINOR_VERSION, &minor);
  return major * 10 + minor;
}

}  // namespace aoscan
