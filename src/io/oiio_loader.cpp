// Finds and opens libdofkit_oiio.so (see oiio_module.hpp).
//
// Places tried, in order: $DOFKIT_OIIO_MODULE; next to the running executable; the install
// layout relative to it (<bin>/../<libdir>/dofkit/); the build tree's copy (a path compiled
// in, for the test and fuzz executables that live in other folders of the build).
#include <dlfcn.h>
#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <mutex>
#include <string>
#include <vector>

#include "dofkit/error.hpp"
#include "io/oiio_module.hpp"

#ifndef DOFKIT_OIIO_MODULE_BUILD_PATH
#define DOFKIT_OIIO_MODULE_BUILD_PATH ""
#endif
#ifndef DOFKIT_OIIO_MODULE_INSTALL_REL
#define DOFKIT_OIIO_MODULE_INSTALL_REL "../lib/dofkit"
#endif

namespace dofkit::io::oiio {

namespace {

constexpr const char* kFile = "libdofkit_oiio.so";

std::vector<std::string> candidates() {
  std::vector<std::string> v;
  if (const char* env = std::getenv("DOFKIT_OIIO_MODULE"); env && *env) v.emplace_back(env);
  std::error_code ec;
  const std::filesystem::path exe = std::filesystem::read_symlink("/proc/self/exe", ec);
  if (!ec) {
    v.push_back((exe.parent_path() / kFile).string());
    v.push_back((exe.parent_path() / DOFKIT_OIIO_MODULE_INSTALL_REL / kFile).lexically_normal().string());
  }
  if (*DOFKIT_OIIO_MODULE_BUILD_PATH) v.emplace_back(DOFKIT_OIIO_MODULE_BUILD_PATH);
  return v;
}

Module* load(std::string& failure) {
  std::string tried;
  for (const std::string& path : candidates()) {
    std::error_code ec;
    if (!std::filesystem::exists(path, ec)) {
      tried += (tried.empty() ? "" : ", ") + path;
      continue;
    }
    void* handle = dlopen(path.c_str(), RTLD_NOW | RTLD_LOCAL);
    if (!handle) {
      const char* e = dlerror();
      failure = path + " does not load: " + (e ? e : "unknown error");
      return nullptr;
    }
    using Entry = Module* (*)();
    auto entry = reinterpret_cast<Entry>(dlsym(handle, "dofkit_oiio_module_v1"));
    if (!entry) {
      failure = path + " has no entry point dofkit_oiio_module_v1";
      return nullptr;
    }
    return entry();  // the module stays loaded for the life of the process
  }
  failure = std::string(kFile) + " not found (looked for " + tried + ")";
  return nullptr;
}

}  // namespace

Module& module() {
  static std::once_flag once;
  static Module* loaded = nullptr;
  static std::string failure;
  std::call_once(once, [] { loaded = load(failure); });
  if (!loaded)
    throw_internal("OpenImageIO module: " + failure +
                   "; it reads and writes every file other than the common EXRs (set DOFKIT_OIIO_MODULE to its path)");
  return *loaded;
}

}  // namespace dofkit::io::oiio
