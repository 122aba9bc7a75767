// The body of `pbdam serve`'s GET /stats: the server's counters, the generation served, the
// render pool's queue, frames and shared GPU cache, the terrain queries, and the process's
// memory (RSS and the C heap), as JSON. Thread-safety: serveStatsJson reads only its
// arguments and the process's own figures; call it from any thread.
#pragma once

#include <cstdint>
#include <map>
#include <nlohmann/json.hpp>
#include <string>

#include "ServeQueries.h"
#include "ServeRenderPool.h"
#include "ServeServer.h"

namespace pbdam::tools {

/// What the server itself counted, read under its locks.
struct ServeCounters final {
  double uptimeSeconds = 0.0;
  std::string directory;  ///< the dataset directory served
  std::uint64_t generation = 1;
  std::uint64_t reloads = 0;
  std::uint64_t failedReloads = 0;
  std::string lastReloadError;
  std::uint64_t requests = 0;
  std::map<int, std::uint64_t> responsesByStatus;
  std::map<std::string, std::uint64_t> requestsByPath;
  std::uint32_t httpThreads = 0;
  std::uint64_t rssBytes = 0;  ///< the process's resident set when the counters were read
};

/// The /stats document, its keys in the order clients and docs know: uptime_s, dataset,
/// server (with the C heap, read here), queries, queue, render, cache.
nlohmann::ordered_json serveStatsJson(const ServeCounters& counters, const RenderPoolStats& pool,
                                      const ServeQueryStats& queries, const ServeOptions& options,
                                      const std::string& deviceName);

}  // namespace pbdam::tools
