// The body of `pbdam serve`'s GET /stats (ServeStats.h).
#include "ServeStats.h"

#include <malloc.h>

#include <algorithm>

namespace pbdam::tools {
namespace {

/// The C heap as glibc's allocator sees it, summed over its arenas: what the program holds
/// (small blocks in arenas plus blocks mapped on their own), and what the arenas keep free
/// without giving it back. Growth of the first is the program's; of the second, fragmentation.
nlohmann::ordered_json heapJson() {
  const struct mallinfo2 m = ::mallinfo2();
  return {{"in_use_bytes", m.uordblks + m.hblkhd},
          {"mapped_blocks_bytes", m.hblkhd},
          {"free_in_arenas_bytes", m.fordblks}};
}

}  // namespace

nlohmann::ordered_json serveStatsJson(const ServeCounters& counters, const RenderPoolStats& pool,
                                      const ServeQueryStats& queries, const ServeOptions& options,
                                      const std::string& deviceName) {
  using Json = nlohmann::ordered_json;
  const RenderPoolStats& s = pool;
  const ServeQueryStats& q = queries;
  Json j;
  j["uptime_s"] = counters.uptimeSeconds;
  j["dataset"] = {{"directory", counters.directory},
                  {"generation", counters.generation},
                  {"reloads", counters.reloads},
                  {"failed_reloads", counters.failedReloads},
                  {"last_reload_error", counters.lastReloadError}};
  Json byStatus = Json::object();
  for (const auto& [status, count] : counters.responsesByStatus) {
    byStatus[std::to_string(status)] = count;
  }
  Json byPath = Json::object();
  for (const auto& [path, count] : counters.requestsByPath) byPath[path] = count;
  j["server"] = {{"requests", counters.requests},
                 {"responses", byStatus},
                 {"paths", byPath},
                 {"http_threads", counters.httpThreads},
                 {"rss_bytes", counters.rssBytes}};
  // Read here, outside the server's locks: mallinfo2 takes every arena's lock in turn.
  j["server"]["heap"] = heapJson();
  j["queries"] = {{"sightlines", q.sightlines},
                  {"viewsheds", q.viewsheds},
                  {"viewshed_hits", q.viewshedHits},
                  {"busy", q.busy}};
  j["queue"] = {{"capacity", s.queueCapacity},
                {"queued", s.queued},
                {"rendering", s.rendering},
                {"peak_queued", s.peakQueued},
                {"rejected_full", s.rejectedQueueFull},
                {"expired", s.expired},
                {"deadline_s", options.deadlineSeconds}};
  const double frames = static_cast<double>(std::max<std::uint64_t>(1, s.frames));
  j["render"] = {{"contexts", s.workers},
                 {"frames_in_flight", options.framesInFlight},
                 {"device", deviceName},
                 {"frames", s.frames},
                 {"errors", s.renderErrors},
                 {"mean_render_ms", s.frames > 0 ? s.renderMsTotal / frames : 0.0},
                 {"mean_queue_ms", s.frames > 0 ? s.queueMsTotal / frames : 0.0},
                 {"multi_pass_frames", s.multiPassFrames}};
  const std::uint64_t lookups = s.hits + s.misses;
  j["cache"] = {
      {"shared_by_contexts", s.workers},
      {"budget_bytes", s.cache.budgetBytes},
      {"resident_bytes", s.cache.residentBytes},
      {"pinned_bytes", s.cache.pinnedBytes},
      {"pool_bytes", s.cache.poolBytes},
      {"resident_patches", s.cache.residentPatches},
      {"resident_tiles", s.cache.residentTiles},
      {"waits_for_room", s.cache.waits},
      {"leases", s.cache.leases},
      {"lock_wait_ms", s.cache.lockWaitMs},
      {"lock_held_ms", s.cache.lockHeldMs},
      {"hits", s.hits},
      {"misses", s.misses},
      {"hit_rate", lookups > 0 ? static_cast<double>(s.hits) / static_cast<double>(lookups) : 0.0},
      {"evictions", s.evictions},
      {"bytes_uploaded", s.bytesUploaded}};
  return j;
}

}  // namespace pbdam::tools
