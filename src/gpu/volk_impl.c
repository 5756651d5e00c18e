/* volk's implementation (Debian ships it as a header-side source file): the Vulkan entry
   points, loaded from libvulkan.so.1 at run time by volkInitialize(). */
#include <volk.c>
