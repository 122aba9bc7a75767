// Loading pbdam's shared modules (Module.h).
#include "pbdam/formats/Module.h"

#include <dlfcn.h>

#include <system_error>
#include <vector>

namespace pbdam::formats {

Result<void*> openModule(const std::string& fileName, const std::filesystem::path& buildPath,
                         int flags) {
  std::vector<std::filesystem::path> places;
  std::error_code ec;
  const std::filesystem::path self = std::filesystem::read_symlink("/proc/self/exe", ec);
  if (!ec) places.push_back(self.parent_path() / fileName);
  if (!buildPath.empty() && (places.empty() || buildPath != places.front())) {
    places.push_back(buildPath);
  }
  std::string tried;
  for (const std::filesystem::path& place : places) {
    tried += (tried.empty() ? "" : "; ") + place.string() + ": ";
    if (!std::filesystem::is_regular_file(place, ec)) {
      tried += "missing";
      continue;
    }
    void* module = ::dlopen(place.c_str(), flags);
    if (module == nullptr) {
      const char* why = ::dlerror();
      tried += why != nullptr ? why : "dlopen failed";
      continue;
    }
    return module;
  }
  // By name: the dynamic linker's search (the caller's RUNPATH, LD_LIBRARY_PATH, ld.so.cache).
  if (!tried.empty()) tried += "; ";
  tried += fileName + " by name: ";
  if (void* module = ::dlopen(fileName.c_str(), flags)) return module;
  const char* why = ::dlerror();
  tried += why != nullptr ? why : "dlopen failed";
  return makeError(ErrorCode::NotFound, fileName + " did not load (" + tried + ")");
}

}  // namespace pbdam::formats
