#pragma once
// OpenGL 3.3 core entry points, linked directly from libOpenGL (GLVND dispatches to the
// current EGL or GLX context), so no loader is needed.
#ifndef GL_GLEXT_PROTOTYPES
#define GL_GLEXT_PROTOTYPES 1
#endif
#include <GL/glcorearb.h>
