// The resident file pages a ResidentTrimmer weighs against its budget (ResidentTrimmer.h).
#include "pbdam/builder/ResidentTrimmer.h"

#include <unistd.h>

#include <cstdio>

namespace pbdam::builder {

std::optional<std::uint64_t> residentFileBytes() noexcept {
  // statm: size resident shared text lib data dt, in pages; "shared" is RssFile + RssShmem.
  std::FILE* f = std::fopen("/proc/self/statm", "r");
  if (f == nullptr) return std::nullopt;
  unsigned long long size = 0;
  unsigned long long resident = 0;
  unsigned long long shared = 0;
  const int read = std::fscanf(f, "%llu %llu %llu", &size, &resident, &shared);
  std::fclose(f);
  const long page = ::sysconf(_SC_PAGESIZE);
  if (read != 3 || page <= 0) return std::nullopt;
  return static_cast<std::uint64_t>(shared) * static_cast<std::uint64_t>(page);
}

}  // namespace pbdam::builder
