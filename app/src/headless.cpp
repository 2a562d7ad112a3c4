#include "kumite/app/headless.hpp"

#include <EGL/egl.h>
#include <EGL/eglext.h>

#include <cstring>
#include <string>

#include <fmt/format.h>

#define STB_IMAGE_WRITE_STATIC
#define STB_IMAGE_WRITE_IMPLEMENTATION
#include <stb/stb_image_write.h>

#include "gl.hpp"
#include "kumite/common/atomic_file.hpp"
#include "kumite/common/error.hpp"

namespace kumite::app {

struct HeadlessContext::Impl {
  EGLDisplay display = EGL_NO_DISPLAY;
  EGLContext context = EGL_NO_CONTEXT;
};

namespace {
[[noreturn]] void egl_fail(const std::string& what) {
  throw Error("gl", "egl",
              fmt::format("headless rendering: {} (EGL error 0x{:x}); needs Mesa's EGL "
                          "(libegl-mesa0) with the surfaceless platform",
                          what, eglGetError()));
}
}  // namespace

HeadlessContext::HeadlessContext() : impl_(std::make_unique<Impl>()) {
  auto get_platform_display = reinterpret_cast<PFNEGLGETPLATFORMDISPLAYEXTPROC>(
      eglGetProcAddress("eglGetPlatformDisplayEXT"));
  if (!get_platform_display) egl_fail("eglGetPlatformDisplayEXT is missing");
  impl_->display = get_platform_display(EGL_PLATFORM_SURFACELESS_MESA, EGL_DEFAULT_DISPLAY, nullptr);
  if (impl_->display == EGL_NO_DISPLAY) egl_fail("no surfaceless EGL display");
  EGLint major = 0, minor = 0;
  if (!eglInitialize(impl_->display, &major, &minor)) egl_fail("eglInitialize failed");
  const EGLint config_attribs[] = {EGL_RENDERABLE_TYPE, EGL_OPENGL_BIT, EGL_SURFACE_TYPE,
                                   EGL_PBUFFER_BIT, EGL_NONE};
  EGLConfig config = nullptr;
  EGLint count = 0;
  if (!eglChooseConfig(impl_->display, config_attribs, &config, 1, &count) || count < 1)
    config = nullptr;  // EGL_KHR_no_config_context: Mesa accepts a context without one
  if (!eglBindAPI(EGL_OPENGL_API)) egl_fail("desktop OpenGL is not available through EGL");
  const EGLint context_attribs[] = {EGL_CONTEXT_MAJOR_VERSION, 3, EGL_CONTEXT_MINOR_VERSION, 3,
                                    EGL_CONTEXT_OPENGL_PROFILE_MASK,
                                    EGL_CONTEXT_OPENGL_CORE_PROFILE_BIT, EGL_NONE};
  impl_->context = eglCreateContext(impl_->display, config, EGL_NO_CONTEXT, context_attribs);
  if (impl_->context == EGL_NO_CONTEXT) egl_fail("no OpenGL 3.3 core context");
  if (!eglMakeCurrent(impl_->display, EGL_NO_SURFACE, EGL_NO_SURFACE, impl_->context))
    egl_fail("cannot make the context current without a surface");
}

HeadlessContext::~HeadlessContext() {
  eglMakeCurrent(impl_->display, EGL_NO_SURFACE, EGL_NO_SURFACE, EGL_NO_CONTEXT);
  eglDestroyContext(impl_->display, impl_->context);
  // No eglTerminate: Mesa's surfaceless display is process-wide and cheap to keep; terminating
  // unloads the driver, whose process-lifetime allocations then show up in leak checkers as
  // leaks from an unknown module (unsuppressible).
}

OffscreenTarget::OffscreenTarget(int width, int height) : width_(width), height_(height) {
  glGenFramebuffers(1, &fbo_);
  glBindFramebuffer(GL_FRAMEBUFFER, fbo_);
  glGenRenderbuffers(1, &colour_);
  glBindRenderbuffer(GL_RENDERBUFFER, colour_);
  glRenderbufferStorage(GL_RENDERBUFFER, GL_RGBA8, width, height);
  glFramebufferRenderbuffer(GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT0, GL_RENDERBUFFER, colour_);
  glGenRenderbuffers(1, &depth_);
  glBindRenderbuffer(GL_RENDERBUFFER, depth_);
  glRenderbufferStorage(GL_RENDERBUFFER, GL_DEPTH_COMPONENT24, width, height);
  glFramebufferRenderbuffer(GL_FRAMEBUFFER, GL_DEPTH_ATTACHMENT, GL_RENDERBUFFER, depth_);
  if (glCheckFramebufferStatus(GL_FRAMEBUFFER) != GL_FRAMEBUFFER_COMPLETE)
    throw Error("gl", "framebuffer", fmt::format("cannot make a {}x{} framebuffer", width, height));
}

OffscreenTarget::~OffscreenTarget() {
  glDeleteFramebuffers(1, &fbo_);
  glDeleteRenderbuffers(1, &colour_);
  glDeleteRenderbuffers(1, &depth_);
}

void OffscreenTarget::bind() const { glBindFramebuffer(GL_FRAMEBUFFER, fbo_); }

void OffscreenTarget::read(std::vector<std::uint8_t>& rgba) const {
  const std::size_t row = static_cast<std::size_t>(width_) * 4;
  rgba.resize(row * static_cast<std::size_t>(height_));
  glBindFramebuffer(GL_READ_FRAMEBUFFER, fbo_);
  glPixelStorei(GL_PACK_ALIGNMENT, 1);
  glReadPixels(0, 0, width_, height_, GL_RGBA, GL_UNSIGNED_BYTE, rgba.data());
  // OpenGL's first row is the bottom one: flip in place.
  std::vector<std::uint8_t> tmp(row);
  for (int y = 0; y < height_ / 2; ++y) {
    auto* a = rgba.data() + static_cast<std::size_t>(y) * row;
    auto* b = rgba.data() + static_cast<std::size_t>(height_ - 1 - y) * row;
    std::memcpy(tmp.data(), a, row);
    std::memcpy(a, b, row);
    std::memcpy(b, tmp.data(), row);
  }
}

void write_png(const std::filesystem::path& path, int width, int height,
               const std::vector<std::uint8_t>& rgba) {
  // Light compression: a 1080p frame encodes several times faster, files ~1.5x bigger.
  stbi_write_png_compression_level = 2;
  int size = 0;
  unsigned char* png = stbi_write_png_to_mem(rgba.data(), width * 4, width, height, 4, &size);
  if (!png) throw Error("io", "png", "cannot encode " + path.string());
  try {
    write_file_atomically(path, std::string_view(reinterpret_cast<const char*>(png),
                                                 static_cast<std::size_t>(size)));
  } catch (...) {
    STBIW_FREE(png);
    throw;
  }
  STBIW_FREE(png);
}

}  // namespace kumite::app
