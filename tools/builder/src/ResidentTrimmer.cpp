// The resident file pages a ResidentTrimmer weighs against its budget (ResidentTrimmer.h).
#include "pbdam/builder/ResidentTrimmer.h"

#include <unistd.h>

#include <fstream>

namespace pbdam::builder {

std::optional<std::uint64_t> residentFileBytes() noexcept {
  // statm: size resident shared text lib data dt, in pages; "shared" is RssFile + RssShmem.
  std::ifstream statm("/proc/self/statm");
  std::uint64_t size = 0;
  std::uint64_t resident = 0;
  std::uint64_t shared = 0;
  if (!(statm >> size >> resident >> shared)) return std::nullopt;
  const long page = ::sysconf(_SC_PAGESIZE);
  if (page <= 0) return std::nullopt;
  return shared * static_cast<std::uint64_t>(page);
}

}  // namespace pbdam::builder
