// This process's resident memory as Linux reports it under /proc/self: the whole resident set
// (`pbdam bench`'s per-frame RSS, `pbdam serve`'s /stats rss_bytes) and its file-backed part
// (mapped dataset pages and libraries, `pbdam bench`'s dataset RSS); and the calling thread's
// major page faults (the render thread's faults of `pbdam bench` and `pbdam fly`). Header-only;
// thread-safety: free functions, no shared state.
#pragma once

#include <sys/resource.h>
#include <unistd.h>

#include <cstdint>
#include <fstream>
#include <string>

namespace pbdam::streaming {

/// Resident set size of this process in bytes: the resident pages of /proc/self/statm times
/// the page size; 0 when the file cannot be read.
inline std::uint64_t residentSetBytes() {
  std::ifstream statm("/proc/self/statm");
  std::uint64_t sizePages = 0;
  std::uint64_t residentPages = 0;
  if (!(statm >> sizePages >> residentPages)) return 0;
  return residentPages * static_cast<std::uint64_t>(::sysconf(_SC_PAGESIZE));
}

/// File-backed resident bytes of this process (RssFile of /proc/self/status: mapped files such
/// as the dataset's pages, and libraries); 0 when the field is absent.
inline std::uint64_t residentFileBytes() {
  std::ifstream status("/proc/self/status");
  std::string line;
  while (std::getline(status, line)) {
    if (line.rfind("RssFile:", 0) == 0) return std::stoull(line.substr(8)) * 1024;  // kB
  }
  return 0;
}

/// Anonymous resident bytes of this process (RssAnon of /proc/self/status: the heap, stacks,
/// copied node tables, the driver's host allocations), the part the kernel cannot drop under a
/// memory limit the way it drops clean file pages; 0 when the field is absent.
inline std::uint64_t anonymousResidentBytes() {
  std::ifstream status("/proc/self/status");
  std::string line;
  while (std::getline(status, line)) {
    if (line.rfind("RssAnon:", 0) == 0) return std::stoull(line.substr(8)) * 1024;  // kB
  }
  return 0;
}

/// Major page faults of the calling thread so far (getrusage RUSAGE_THREAD).
inline std::uint64_t threadMajorFaults() {
  rusage usage{};
  ::getrusage(RUSAGE_THREAD, &usage);
  return static_cast<std::uint64_t>(usage.ru_majflt);
}

}  // namespace pbdam::streaming
