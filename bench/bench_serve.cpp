// Load benchmark of `pbdam serve`: starts the server on a free loopback port, then for
// each concurrency level sends a bounded number of GET /frame requests from that many client
// threads (httplib's client, keep-alive) and reports frames/s, p50/p99 latency, errors (503s and
// anything else) and the server's RSS: after warm-up, its maximum during the run and the end.
// Clients that get a 503 wait the Retry-After the server sends before their next request, as a
// polite client does. The cameras loop over a closed orbit of --period views; the warm-up (one
// loop by default) lets the GPU caches take in that working set, so RSS growth after it would
// be a leak, not the cache filling. Per level it also reads the server's GET /stats before and
// after the measured requests: the shared GPU cache's hit rate and bytes uploaded during them.
// Loopback only; every phase is bounded in count and time.
//   pbdam_bench_serve PBDAM_EXE DATASET [--requests 2000] [--concurrency 4,16] [--workers 4]
//                     [--queue 8] [--gpu-cache-mb 256] [--width 640] [--height 480]
//                     [--period 1000] [--warmup P] [--time-limit-s 600] [--json FILE]
#include <httplib.h>
#include <poll.h>
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <fstream>
#include <mutex>
#include <nlohmann/json.hpp>
#include <optional>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "ServeHarness.h"

namespace {

using pbdam::bench::percentile;
using pbdam::bench::rssMiB;
using pbdam::bench::Server;
using pbdam::bench::startServer;

using Clock = std::chrono::steady_clock;

struct Options {
  std::string pbdam;
  std::string dataset;
  int requests = 2000;
  std::vector<int> concurrency = {4, 16};
  int workers = 4;
  int queue = 8;
  double gpuCacheMiB = 256.0;
  int width = 640;
  int height = 480;
  int period = 1000;
  int warmup = -1;  ///< -1: one period
  double timeLimitSeconds = 600.0;
  std::string json;
};

struct Phase {
  int concurrency = 0;
  int sent = 0;
  int ok = 0;
  int refused = 0;  ///< 503
  int failed = 0;   ///< anything else: other statuses, connection errors
  double seconds = 0.0;
  double p50Ms = 0.0;
  double p99Ms = 0.0;
  double maxMs = 0.0;
  double rssWarmMiB = 0.0;      ///< idle, right after the warm-up
  double rssWarmPeakMiB = 0.0;  ///< the most during the warm-up
  double rssMaxMiB = 0.0;       ///< the most during the run
  double rssEndMiB = 0.0;       ///< idle, right after the run
  bool timedOut = false;
  // The GPU cache during the measured requests (GET /stats differences).
  double cacheHitRate = 0.0;
  double cacheUploadedMiB = 0.0;
  double cacheResidentMiB = 0.0;  ///< after the run
  /// The cache's lock during the run: passes' reservations, and per frame the milliseconds a
  /// pass waited for another context's reservation and held the lock itself.
  double leases = 0.0;
  double lockWaitMsPerFrame = 0.0;
  double lockHeldMsPerFrame = 0.0;
};

/// The GPU cache counters of GET /stats (zeros when the request fails).
struct CacheCounters {
  double hits = 0.0;
  double misses = 0.0;
  double uploadedBytes = 0.0;
  double residentBytes = 0.0;
  double leases = 0.0;
  double lockWaitMs = 0.0;
  double lockHeldMs = 0.0;
};

CacheCounters cacheCounters(int port) {
  httplib::Client client("127.0.0.1", port);
  client.set_read_timeout(std::chrono::seconds(30));
  CacheCounters c;
  const auto res = client.Get("/stats");
  if (!res || res->status != 200) return c;
  const auto j = nlohmann::json::parse(res->body, nullptr, false);
  if (j.is_discarded() || !j.contains("cache")) return c;
  const auto& cache = j["cache"];
  c.hits = cache.value("hits", 0.0);
  c.misses = cache.value("misses", 0.0);
  c.uploadedBytes = cache.value("bytes_uploaded", 0.0);
  c.residentBytes = cache.value("resident_bytes", 0.0);
  c.leases = cache.value("leases", 0.0);
  c.lockWaitMs = cache.value("lock_wait_ms", 0.0);
  c.lockHeldMs = cache.value("lock_held_ms", 0.0);
  return c;
}

/// The i-th camera: a closed orbit of `period` views once around the planet at 1,000–3,000 km,
/// weaving ±40° in latitude, looking down and ahead, so successive requests differ but share
/// much of the cut (as a flight does).
std::string frameQuery(int i, const Options& o) {
  const double kTwoPi = 6.283185307179586;
  const double u = static_cast<double>(i % o.period) / static_cast<double>(o.period);  // 0..1
  char text[256];
  std::snprintf(text, sizeof text,
                "/frame?lat=%.4f&lon=%.4f&alt=%.0f&heading=%.1f&pitch=-60&width=%d&height=%d",
                40.0 * std::sin(3.0 * kTwoPi * u), 360.0 * u - 180.0,
                2.0e6 + 1.0e6 * std::sin(5.0 * kTwoPi * u), std::fmod(360.0 * 7.0 * u, 360.0),
                o.width, o.height);
  return text;
}

/// Sends `count` requests (numbered from `first`) from `concurrency` threads.
Phase runPhase(int port, pid_t server, int first, int count, int concurrency, const Options& o) {
  Phase phase;
  phase.concurrency = concurrency;
  std::atomic<int> next{0};
  std::mutex mutex;
  std::vector<double> latencies;
  const auto start = Clock::now();
  const auto stopAt = start + std::chrono::duration_cast<Clock::duration>(
                                  std::chrono::duration<double>(o.timeLimitSeconds));
  std::atomic<bool> done{false};
  double rssMax = 0.0;
  std::thread sampler([&] {
    while (!done.load()) {
      rssMax = std::max(rssMax, rssMiB(server));
      std::this_thread::sleep_for(std::chrono::milliseconds(100));
    }
  });
  std::vector<std::thread> clients;
  clients.reserve(static_cast<std::size_t>(concurrency));
  for (int c = 0; c < concurrency; ++c) {
    clients.emplace_back([&] {
      httplib::Client client("127.0.0.1", port);
      client.set_read_timeout(120, 0);
      client.set_keep_alive(true);
      for (int i = next++; i < count; i = next++) {
        if (Clock::now() > stopAt) {
          const std::lock_guard<std::mutex> lock(mutex);
          phase.timedOut = true;
          return;
        }
        const auto sent = Clock::now();
        auto res = client.Get(frameQuery(first + i, o));
        const double ms = std::chrono::duration<double, std::milli>(Clock::now() - sent).count();
        int retryAfter = 0;
        {
          const std::lock_guard<std::mutex> lock(mutex);
          ++phase.sent;
          if (res && res->status == 200) {
            ++phase.ok;
            latencies.push_back(ms);
          } else if (res && res->status == 503) {
            ++phase.refused;
            retryAfter = std::max(1, std::atoi(res->get_header_value("Retry-After").c_str()));
          } else {
            ++phase.failed;
          }
        }
        if (retryAfter > 0) std::this_thread::sleep_for(std::chrono::seconds(retryAfter));
      }
    });
  }
  for (std::thread& t : clients) t.join();
  done = true;
  sampler.join();
  phase.seconds = std::chrono::duration<double>(Clock::now() - start).count();
  phase.p50Ms = percentile(latencies, 0.50);
  phase.p99Ms = percentile(latencies, 0.99);
  phase.maxMs = latencies.empty() ? 0.0 : *std::max_element(latencies.begin(), latencies.end());
  phase.rssMaxMiB = rssMax;
  phase.rssEndMiB = rssMiB(server);
  return phase;
}

int usage(const char* message) {
  std::fprintf(stderr,
               "pbdam_bench_serve: %s\nusage: pbdam_bench_serve PBDAM_EXE DATASET [--requests N] "
               "[--concurrency A,B,...] [--workers N] [--queue N] [--gpu-cache-mb M] [--width W] "
               "[--height H] "
               "[--period N] [--warmup N] [--time-limit-s S] [--json FILE]\n",
               message);
  return 2;
}

/// Parses the command line; nullopt, with `why` set, when it is not usable.
std::optional<Options> parseOptions(const std::vector<std::string>& args, const char*& why) {
  Options o;
  std::vector<std::string> positional;
  for (std::size_t i = 0; i < args.size(); ++i) {
    const std::string& a = args[i];
    const auto value = [&]() -> std::string {
      if (i + 1 >= args.size()) return {};
      return args[++i];
    };
    if (a == "--requests") {
      o.requests = std::atoi(value().c_str());
    } else if (a == "--concurrency") {
      o.concurrency.clear();
      std::stringstream list(value());
      for (std::string item; std::getline(list, item, ',');) {
        o.concurrency.push_back(std::atoi(item.c_str()));
      }
    } else if (a == "--workers") {
      o.workers = std::atoi(value().c_str());
    } else if (a == "--queue") {
      o.queue = std::atoi(value().c_str());
    } else if (a == "--gpu-cache-mb") {
      o.gpuCacheMiB = std::atof(value().c_str());
    } else if (a == "--width") {
      o.width = std::atoi(value().c_str());
    } else if (a == "--height") {
      o.height = std::atoi(value().c_str());
    } else if (a == "--period") {
      o.period = std::atoi(value().c_str());
    } else if (a == "--warmup") {
      o.warmup = std::atoi(value().c_str());
    } else if (a == "--time-limit-s") {
      o.timeLimitSeconds = std::atof(value().c_str());
    } else if (a == "--json") {
      o.json = value();
    } else {
      positional.push_back(a);
    }
  }
  why = "expected PBDAM_EXE and DATASET";
  if (positional.size() != 2) return std::nullopt;
  o.pbdam = positional[0];
  o.dataset = positional[1];
  if (o.warmup < 0) o.warmup = o.period;
  if (o.requests < 1 || o.requests > 100000 || o.warmup < 0 || o.warmup > 100000 || o.period < 1 ||
      o.period > 100000 || o.concurrency.empty() ||
      std::any_of(o.concurrency.begin(), o.concurrency.end(),
                  [](int c) { return c < 1 || c > 256; }) ||
      !(o.timeLimitSeconds > 0.0) || !(o.gpuCacheMiB > 0.0)) {
    why = "bad option value";
    return std::nullopt;
  }
  return o;
}

/// Warms up and measures one concurrency level `c`; `first` is the first request's index and
/// advances past the requests sent.
Phase measureLevel(int port, pid_t server, int c, int& first, const Options& o) {
  // Warm-up at the level's concurrency: caches fill, pools and allocator arenas reach size.
  double warmPeak = 0.0;
  if (o.warmup > 0) warmPeak = runPhase(port, server, first, o.warmup, c, o).rssMaxMiB;
  first += o.warmup;
  const double warmRss = rssMiB(server);
  const CacheCounters before = cacheCounters(port);
  Phase phase = runPhase(port, server, first, o.requests, c, o);
  const CacheCounters after = cacheCounters(port);
  const double lookups = (after.hits - before.hits) + (after.misses - before.misses);
  phase.cacheHitRate = lookups > 0.0 ? (after.hits - before.hits) / lookups : 0.0;
  phase.cacheUploadedMiB = (after.uploadedBytes - before.uploadedBytes) / 1048576.0;
  phase.cacheResidentMiB = after.residentBytes / 1048576.0;
  phase.leases = after.leases - before.leases;
  const double frames = std::max(1, phase.ok);
  phase.lockWaitMsPerFrame = (after.lockWaitMs - before.lockWaitMs) / frames;
  phase.lockHeldMsPerFrame = (after.lockHeldMs - before.lockHeldMs) / frames;
  first += o.requests;
  phase.rssWarmMiB = warmRss;
  phase.rssWarmPeakMiB = warmPeak;
  const auto change = [](double from, double to) {
    return 100.0 * (to - from) / std::max(1.0, from);
  };
  std::printf(
      "concurrency %2d: %d requests in %.1f s: %.1f frames/s, latency p50 %.1f ms p99 %.1f ms "
      "max %.1f ms, errors %d (503 %d, other %d)%s\n"
      "  RSS idle after warm-up %.0f MiB, idle after the run %.0f MiB (%+.1f%%); peak during "
      "warm-up %.0f MiB, during the run %.0f MiB (%+.1f%%)\n"
      "  GPU cache during the run: hit rate %.1f%%, %.1f MiB uploaded, %.1f MiB resident after "
      "it; its lock a frame: waited %.2f ms, held %.2f ms (%.0f reservations)\n",
      c, phase.sent, phase.seconds, phase.ok / phase.seconds, phase.p50Ms, phase.p99Ms, phase.maxMs,
      phase.refused + phase.failed, phase.refused, phase.failed,
      phase.timedOut ? " (time limit reached)" : "", phase.rssWarmMiB, phase.rssEndMiB,
      change(phase.rssWarmMiB, phase.rssEndMiB), phase.rssWarmPeakMiB, phase.rssMaxMiB,
      change(phase.rssWarmPeakMiB, phase.rssMaxMiB), 100.0 * phase.cacheHitRate,
      phase.cacheUploadedMiB, phase.cacheResidentMiB, phase.lockWaitMsPerFrame,
      phase.lockHeldMsPerFrame, phase.leases);
  return phase;
}

void writeJson(const std::string& path, const std::vector<Phase>& phases) {
  std::ofstream out(path);
  out << "[\n";
  for (std::size_t i = 0; i < phases.size(); ++i) {
    const Phase& p = phases[i];
    out << "  {\"concurrency\": " << p.concurrency << ", \"requests\": " << p.sent
        << ", \"ok\": " << p.ok << ", \"refused_503\": " << p.refused
        << ", \"failed\": " << p.failed << ", \"seconds\": " << p.seconds
        << ", \"frames_per_s\": " << p.ok / p.seconds << ", \"p50_ms\": " << p.p50Ms
        << ", \"p99_ms\": " << p.p99Ms << ", \"max_ms\": " << p.maxMs
        << ", \"rss_warm_mib\": " << p.rssWarmMiB << ", \"rss_warm_peak_mib\": " << p.rssWarmPeakMiB
        << ", \"rss_max_mib\": " << p.rssMaxMiB << ", \"rss_end_mib\": " << p.rssEndMiB
        << ", \"cache_hit_rate\": " << p.cacheHitRate
        << ", \"cache_uploaded_mib\": " << p.cacheUploadedMiB
        << ", \"cache_resident_mib\": " << p.cacheResidentMiB
        << ", \"cache_lock_wait_ms_per_frame\": " << p.lockWaitMsPerFrame
        << ", \"cache_lock_held_ms_per_frame\": " << p.lockHeldMsPerFrame << "}"
        << (i + 1 < phases.size() ? "," : "") << "\n";
  }
  out << "]\n";
}

int run(const std::vector<std::string>& args) {
  const char* why = "";
  const std::optional<Options> parsed = parseOptions(args, why);
  if (!parsed) return usage(why);
  const Options& o = *parsed;
  const Server started =
      startServer(o.pbdam, o.dataset,
                  {"--workers", std::to_string(o.workers), "--queue", std::to_string(o.queue),
                   "--gpu-cache-mb", std::to_string(o.gpuCacheMiB)});
  if (!started.spawned) return usage("cannot start PBDAM_EXE");
  if (started.pid < 0) return 1;
  const pid_t server = started.pid;
  const int port = started.port;
  std::printf("%s", started.startLine.c_str());
  std::printf(
      "%d requests of %dx%d per level after a warm-up of %d (cameras loop over %d views), server "
      "--workers %d --queue %d --gpu-cache-mb %.0f\n",
      o.requests, o.width, o.height, o.warmup, o.period, o.workers, o.queue, o.gpuCacheMiB);

  std::vector<Phase> phases;
  int first = 0;
  for (const int c : o.concurrency) {
    phases.push_back(measureLevel(port, server, c, first, o));
    std::fflush(stdout);
  }

  ::kill(server, SIGTERM);
  int status = 0;
  ::waitpid(server, &status, 0);
  const bool cleanExit = WIFEXITED(status) && WEXITSTATUS(status) == 0;
  std::printf("server exit after SIGTERM: %s\n", cleanExit ? "0" : "FAILED");

  if (!o.json.empty()) writeJson(o.json, phases);
  const bool errorsAtLowConcurrency = std::any_of(
      phases.begin(), phases.end(),
      [&](const Phase& p) { return p.concurrency <= o.workers && (p.refused + p.failed) > 0; });
  return cleanExit && !errorsAtLowConcurrency ? 0 : 1;
}

}  // namespace

int main(int argc, char** argv) {
  try {
    return run(std::vector<std::string>(argv + 1, argv + argc));
  } catch (const std::exception& e) {
    std::fprintf(stderr, "pbdam_bench_serve: %s\n", e.what());
  } catch (...) {
    std::fprintf(stderr, "pbdam_bench_serve: unknown exception\n");
  }
  return 1;
}
