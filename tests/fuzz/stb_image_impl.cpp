// The fuzz targets compile stb_image's implementation themselves, so that it is instrumented
// (coverage, AddressSanitizer) instead of coming from Debian's uninstrumented libstb.
#define STB_IMAGE_IMPLEMENTATION
#include <stb/stb_image.h>
