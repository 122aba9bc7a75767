// Soak test of `pbdam serve`: runs the server on a free loopback port for --duration-s under a
// steady mix — valid frames (a looping orbit), heights, malformed requests (bad and repeated
// parameters, unknown paths, wrong methods, oversized targets, garbage request lines), slow
// clients that send a request and never read the reply or never finish their headers, and
// bursts of simultaneous frames beyond the render queue — and reports, per window, requests
// served, 4xx and 503 counts and frame latency p50/p99, with the server's anonymous RSS and open
// descriptors, and from its /stats the C heap in use, the heap kept free by the allocator and the
// GPU cache's memory; from the first window after the warm-up to the end, the drift of RSS and
// descriptors; crashes (the server gone before the stop, or not exiting cleanly on SIGTERM);
// and sampled frames served under load
// compared byte for byte with `pbdam render` of the same camera. Every client is bounded (count
// of open slow connections, burst size) and stops at the deadline.
//   pbdam_serve_soak PBDAM_EXE DATASET [--duration-s 1800] [--warmup-s 60] [--window-s 60]
//                    [--workers 2] [--queue 4] [--width 320] [--height 240] [--compare 4]
//                    [--check-flat]
// Exit code 0 when there was no crash, no wrong frame, no 5xx besides 503, and the server
// still answered at the end (with --check-flat also: anonymous RSS and descriptors within 5%
// of the first window's after the warm-up, last window's p99 within 1.5x of that window's); 1
// otherwise.
#include <httplib.h>

#include <nlohmann/json.hpp>

#include <atomic>
#include <condition_variable>
#include <cstdio>
#include <cstring>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include "ServeHarness.h"

namespace {

using namespace pbdam::bench;
using Clock = std::chrono::steady_clock;

struct Options {
  std::string pbdam;
  std::string dataset;
  double durationSeconds = 1800.0;
  double warmupSeconds = 60.0;
  double windowSeconds = 60.0;
  int workers = 2;
  int queue = 4;
  int width = 320;
  int height = 240;
  int compare = 4;
  bool checkFlat = false;
};

/// Counters shared by the client threads (under `mutex`).
struct Tally {
  std::mutex mutex;
  long served = 0;             ///< 2xx
  long clientErrors = 0;       ///< 4xx
  long refused = 0;            ///< 503
  long serverErrors = 0;       ///< other 5xx: a bug
  long noReply = 0;            ///< connection errors, timeouts
  long malformedAccepted = 0;  ///< a malformed request answered 2xx: a bug
  std::vector<std::pair<double, double>> frameLatencies;  ///< (seconds since start, ms)
  struct Sample {
    std::string camera;  ///< lat,lon,alt,heading,pitch,roll as sent
    std::string png;
  };
  std::vector<Sample> samples;
};

/// The i-th camera of a closed orbit of 600 views at 1,000–3,000 km, looking down and ahead, as
/// the text both `GET /frame` and `pbdam render --camera` take, so both parse the same doubles.
struct Camera {
  std::string lat, lon, alt, heading;
  std::string cli() const { return lat + "," + lon + "," + alt + "," + heading + ",-60,0"; }
};

Camera camera(int i) {
  const double kTwoPi = 6.283185307179586;
  const double u = static_cast<double>(i % 600) / 600.0;
  char lat[32], lon[32], alt[32], heading[32];
  std::snprintf(lat, sizeof lat, "%.4f", 40.0 * std::sin(3.0 * kTwoPi * u));
  std::snprintf(lon, sizeof lon, "%.4f", 360.0 * u - 180.0);
  std::snprintf(alt, sizeof alt, "%.0f", 2.0e6 + 1.0e6 * std::sin(5.0 * kTwoPi * u));
  std::snprintf(heading, sizeof heading, "%.1f", std::fmod(360.0 * 7.0 * u, 360.0));
  return {lat, lon, alt, heading};
}

std::string frameTarget(const Camera& c, const Options& o) {
  return "/frame?lat=" + c.lat + "&lon=" + c.lon + "&alt=" + c.alt + "&heading=" + c.heading +
         "&pitch=-60&width=" + std::to_string(o.width) + "&height=" + std::to_string(o.height);
}

void count(Tally& t, const httplib::Result& res) {
  const std::lock_guard lock(t.mutex);
  if (!res) {
    ++t.noReply;
  } else if (res->status < 300) {
    ++t.served;
  } else if (res->status == 503) {
    ++t.refused;
  } else if (res->status < 500) {
    ++t.clientErrors;
  } else {
    ++t.serverErrors;
  }
}

class Soak {
 public:
  Soak(const Options& o, int port, pid_t server) : o_(o), port_(port), server_(server) {}
  int run();

 private:
  bool running() const { return !stop_.load(); }
  double now() const { return std::chrono::duration<double>(Clock::now() - start_).count(); }
  /// Sleeps `ms` or until the stop, whichever is first.
  void pause(int ms) {
    std::unique_lock lock(stopMutex_);
    stopCv_.wait_for(lock, std::chrono::milliseconds(ms), [&] { return stop_.load(); });
  }
  void frames(int thread);
  void heights();
  void malformed();
  void slowClients();
  void bursts();
  bool serverAlive();
  int compareFrames();
  struct Window;
  void readServerMemory(Window& w) const;
  int report(const std::vector<Window>& windows, const std::optional<Window>& warm, bool answers,
             int wrong, int crashes);

  const Options& o_;
  int port_;
  pid_t server_;
  Tally t_;
  Clock::time_point start_ = Clock::now();
  std::atomic<bool> stop_{false};
  std::atomic<bool> crashed_{false};
  std::mutex stopMutex_;
  std::condition_variable stopCv_;
};

void Soak::frames(int thread) {
  httplib::Client client("127.0.0.1", port_);
  client.set_read_timeout(60, 0);
  client.set_keep_alive(true);
  for (int i = thread * 300; running(); ++i) {
    const Camera cam = camera(i);
    const auto sent = Clock::now();
    auto res = client.Get(frameTarget(cam, o_));
    const double ms = std::chrono::duration<double, std::milli>(Clock::now() - sent).count();
    count(t_, res);
    if (res && res->status == 200) {
      const std::lock_guard lock(t_.mutex);
      t_.frameLatencies.emplace_back(now(), ms);
      // Every 97th frame after the warm-up is kept for comparison, up to --compare of them.
      if (i % 97 == 0 && now() > o_.warmupSeconds &&
          static_cast<int>(t_.samples.size()) < o_.compare) {
        t_.samples.push_back({cam.cli(), res->body});
      }
    } else if (res && res->status == 503) {
      pause(std::max(1, std::atoi(res->get_header_value("Retry-After").c_str())) * 1000);
    }
  }
}

void Soak::heights() {
  httplib::Client client("127.0.0.1", port_);
  client.set_read_timeout(30, 0);
  for (int i = 0; running(); ++i) {
    char target[96];
    std::snprintf(target, sizeof target, "/height?lat=%.3f&lon=%.3f", -80.0 + (i * 7) % 160,
                  -180.0 + (i * 13) % 360);
    count(t_, client.Get(target));
    pause(20);
  }
}

void Soak::malformed() {
  httplib::Client client("127.0.0.1", port_);
  client.set_read_timeout(30, 0);
  const std::vector<std::string> targets = {"/frame?lat=abc&lon=0&alt=1e6",
                                            "/frame?lat=1&lon=2",
                                            "/frame?lat=1&lat=2&lon=3&alt=4",
                                            "/frame?lat=1&lon=2&alt=3e6&width=99999",
                                            "/frame?lat=nan&lon=0&alt=1e6",
                                            "/height?lat=91&lon=0",
                                            "/height?lat=1&lon=2&x=3",
                                            "/no/such/path",
                                            "/info?x=1",
                                            "/frame?" + std::string(6000, 'a')};
  const std::vector<std::string> raw = {"GARBAGE\r\n\r\n", "GET\r\n\r\n",
                                        "GET /frame?lat=%zz HTTP/1.1\r\nHost: x\r\n\r\n",
                                        "GET /" + std::string(20000, 'x') + " HTTP/1.1\r\n\r\n"};
  for (std::size_t i = 0; running(); ++i) {
    int status = 0;
    if (i % 5 == 4) {
      status = rawStatus(port_, raw[(i / 5) % raw.size()]);
    } else if (i % 7 == 3) {
      auto res = client.Post("/frame", "x", "text/plain");
      status = res ? res->status : 0;
    } else {
      auto res = client.Get(targets[i % targets.size()]);
      status = res ? res->status : 0;
    }
    {
      const std::lock_guard lock(t_.mutex);
      if (status == 0) ++t_.noReply;  // a server may just close on garbage: counted, not a bug
      if (status >= 200 && status < 300) ++t_.malformedAccepted;
      if (status >= 400 && status < 500) ++t_.clientErrors;
      if (status >= 500 && status != 503) ++t_.serverErrors;
      if (status == 503) ++t_.refused;
    }
    pause(50);
  }
}

void Soak::slowClients() {
  // At most 3 open at once: one that sends a large frame request and never reads, one that
  // never finishes its headers, held 10 s each, then closed.
  struct Held {
    int fd;
    Clock::time_point until;
  };
  std::vector<Held> held;
  for (int i = 0; running(); ++i) {
    for (auto it = held.begin(); it != held.end();) {
      if (Clock::now() >= it->until) {
        ::close(it->fd);
        it = held.erase(it);
      } else {
        ++it;
      }
    }
    if (held.size() < 3) {
      const int fd = connectLoopback(port_);
      if (fd >= 0) {
        const std::string request =
            i % 2 == 0 ? "GET " + frameTarget(camera(i), o_) + " HTTP/1.1\r\nHost: soak\r\n\r\n"
                       : "GET /frame?lat=1&lon=2&alt=3e6 HTTP/1.1\r\nHost: so";
        (void)::send(fd, request.data(), request.size(), MSG_NOSIGNAL);
        held.push_back({fd, Clock::now() + std::chrono::seconds(10)});
      }
    }
    pause(2000);
  }
  for (const Held& h : held) ::close(h.fd);
}

void Soak::bursts() {
  // Every 15 s, workers + queue + 6 frames at once on fresh connections: some get a 503.
  while (running()) {
    pause(15000);
    if (!running()) break;
    std::vector<std::thread> burst;
    const int n = o_.workers + o_.queue + 6;
    burst.reserve(static_cast<std::size_t>(n));
    for (int k = 0; k < n; ++k) {
      burst.emplace_back([this, k] {
        httplib::Client client("127.0.0.1", port_);
        client.set_read_timeout(60, 0);
        count(t_, client.Get(frameTarget(camera(1000 + k * 37), o_)));
      });
    }
    for (std::thread& b : burst) b.join();
  }
}

bool Soak::serverAlive() {
  int status = 0;
  if (::waitpid(server_, &status, WNOHANG) == server_) {
    crashed_ = true;
    std::fprintf(stderr, "serve_soak: the server exited during the run (status %d)\n", status);
    return false;
  }
  return !crashed_;
}

/// Renders each sampled camera with `pbdam render`; the number whose PNG differs.
int Soak::compareFrames() {
  int wrong = 0;
  const std::string png = "/tmp/pbdam-serve-soak-" + std::to_string(::getpid()) + ".png";
  for (const Tally::Sample& s : t_.samples) {
    const std::string command = "'" + o_.pbdam + "' render '" + o_.dataset + "' --camera " +
                                s.camera + " --width " + std::to_string(o_.width) + " --height " +
                                std::to_string(o_.height) + " --out '" + png +
                                "' --quiet >/dev/null 2>&1";
    const int rc = std::system(command.c_str());
    std::ifstream in(png, std::ios::binary);
    const std::string expected((std::istreambuf_iterator<char>(in)), {});
    if (rc != 0 || expected != s.png) {
      ++wrong;
      std::fprintf(stderr, "serve_soak: frame at camera %s differs from pbdam render's\n",
                   s.camera.c_str());
    }
  }
  std::remove(png.c_str());
  return wrong;
}

struct Soak::Window {
  double endSeconds = 0.0;
  double p50Ms = 0.0;
  double p99Ms = 0.0;
  long frames = 0;
  double anonMiB = 0.0;
  int fds = 0;
  // From the server's /stats: the C heap in use and kept free by the allocator, and the GPU
  // cache's device memory (host memory on lavapipe). Negative: /stats did not answer.
  double heapMiB = -1.0;
  double heapFreeMiB = -1.0;
  double cacheMiB = -1.0;
  double residentMiB = -1.0;  ///< of the cache: the patches and tiles in it
};

/// The memory figures of the server's /stats into `w` (left negative when it does not answer).
void Soak::readServerMemory(Window& w) const {
  httplib::Client client("127.0.0.1", port_);
  client.set_read_timeout(10, 0);
  const auto res = client.Get("/stats");
  if (!res || res->status != 200) return;
  const auto stats = nlohmann::json::parse(res->body, nullptr, false);
  if (stats.is_discarded()) return;
  constexpr double kMiB = 1024.0 * 1024.0;
  const auto mib = [&](const nlohmann::json::json_pointer& at) {
    return stats.contains(at) ? stats[at].get<double>() / kMiB : -1.0;
  };
  using P = nlohmann::json::json_pointer;
  w.heapMiB = mib(P("/server/heap/in_use_bytes"));
  w.heapFreeMiB = mib(P("/server/heap/free_in_arenas_bytes"));
  w.cacheMiB = mib(P("/cache/pool_bytes"));
  w.residentMiB = mib(P("/cache/resident_bytes"));
}

int Soak::run() {
  std::vector<std::thread> clients;
  clients.emplace_back([this] { frames(0); });
  clients.emplace_back([this] { frames(1); });
  clients.emplace_back([this] { heights(); });
  clients.emplace_back([this] { malformed(); });
  clients.emplace_back([this] { slowClients(); });
  clients.emplace_back([this] { bursts(); });

  std::printf("%8s %8s %6s %6s %7s %9s %9s %10s %8s %9s %9s %10s %10s\n", "t_s", "served", "4xx",
              "503", "frames", "p50_ms", "p99_ms", "anon_MiB", "min_fds", "heap_MiB", "free_MiB",
              "cache_MiB", "cached_MiB");
  std::vector<Window> windows;
  std::optional<Window> warm;
  std::size_t seen = 0;
  while (now() < o_.durationSeconds && serverAlive()) {
    const double end = std::min(o_.durationSeconds,
                                (static_cast<double>(windows.size()) + 1.0) * o_.windowSeconds);
    // Descriptors: the fewest seen in the window, so that the connections of the moment (slow
    // clients, bursts) do not hide or fake a leak.
    int fewestFds = openFds(server_);
    while (now() < end && serverAlive()) {
      std::this_thread::sleep_for(std::chrono::milliseconds(200));
      fewestFds = std::min(fewestFds, openFds(server_));
    }
    Window w;
    w.endSeconds = now();
    w.anonMiB = procStatusMiB(server_, "RssAnon:");
    w.fds = fewestFds;
    readServerMemory(w);
    long served = 0, clientErrors = 0, refused = 0;
    {
      const std::lock_guard lock(t_.mutex);
      std::vector<double> ms;
      for (std::size_t k = seen; k < t_.frameLatencies.size(); ++k) {
        ms.push_back(t_.frameLatencies[k].second);
      }
      seen = t_.frameLatencies.size();
      w.frames = static_cast<long>(ms.size());
      w.p50Ms = percentile(ms, 0.50);
      w.p99Ms = percentile(ms, 0.99);
      served = t_.served;
      clientErrors = t_.clientErrors;
      refused = t_.refused;
    }
    std::printf("%8.0f %8ld %6ld %6ld %7ld %9.1f %9.1f %10.1f %8d %9.1f %9.1f %10.1f %10.1f\n",
                w.endSeconds, served, clientErrors, refused, w.frames, w.p50Ms, w.p99Ms, w.anonMiB,
                w.fds, w.heapMiB, w.heapFreeMiB, w.cacheMiB, w.residentMiB);
    std::fflush(stdout);
    // The baseline is the first whole window after the warm-up: one that overlaps the warm-up
    // still sees the slow clients and the cache filling up.
    const double start = windows.empty() ? 0.0 : windows.back().endSeconds;
    if (!warm && start >= o_.warmupSeconds - 0.5) warm = w;
    windows.push_back(w);
  }
  stop_ = true;
  stopCv_.notify_all();
  for (std::thread& c : clients) c.join();

  // The server must still answer after all of it.
  httplib::Client client("127.0.0.1", port_);
  client.set_read_timeout(30, 0);
  const auto info = client.Get("/info");
  const bool answers = serverAlive() && info && info->status == 200;
  const int wrong = crashed_ ? 0 : compareFrames();
  ::kill(server_, SIGTERM);
  int status = 0;
  const bool exited = !crashed_ && ::waitpid(server_, &status, 0) == server_;
  const bool cleanExit = exited && WIFEXITED(status) && WEXITSTATUS(status) == 0;
  const int crashes = (crashed_ ? 1 : 0) + (exited && !cleanExit ? 1 : 0);
  return report(windows, warm, answers, wrong, crashes);
}

}  // namespace

namespace {

int Soak::report(const std::vector<Window>& windows, const std::optional<Window>& warm,
                 bool answers, int wrong, int crashes) {
  const std::lock_guard lock(t_.mutex);
  std::printf(
      "requests: %ld served, %ld 4xx, %ld 503, %ld other 5xx, %ld without a reply, %ld malformed "
      "accepted\n",
      t_.served, t_.clientErrors, t_.refused, t_.serverErrors, t_.noReply, t_.malformedAccepted);
  bool flat = true;
  if (warm && !windows.empty()) {
    const Window& end = windows.back();
    const auto change = [](double from, double to) {
      return 100.0 * (to - from) / std::max(1.0, from);
    };
    // The same window is the latency baseline.
    const Window* first = warm->frames > 0 ? &*warm : nullptr;
    const double p99Ratio = first != nullptr && first->p99Ms > 0.0 ? end.p99Ms / first->p99Ms : 0.0;
    std::printf(
        "first window after the warm-up (ending %.0f s) -> end (%.0f s): anonymous RSS %.1f -> "
        "%.1f MiB (%+.1f%%), open "
        "fds %d -> %d (%+.1f%%), p99 %.1f -> %.1f ms (x%.2f)\n",
        warm->endSeconds, end.endSeconds, warm->anonMiB, end.anonMiB,
        change(warm->anonMiB, end.anonMiB), warm->fds, end.fds, change(warm->fds, end.fds),
        first ? first->p99Ms : 0.0, end.p99Ms, p99Ratio);
    flat = std::abs(change(warm->anonMiB, end.anonMiB)) <= 5.0 &&
           std::abs(change(warm->fds, end.fds)) <= 5.0 && p99Ratio <= 1.5;
    std::printf("flat (RSS and fds within 5%%, p99 within 1.5x): %s\n", flat ? "yes" : "NO");
  }
  std::printf(
      "crashes: %d; frames compared with pbdam render: %zu, wrong: %d; server answered "
      "at the end: %s\n",
      crashes, t_.samples.size(), wrong, answers ? "yes" : "NO");
  const bool ok = crashes == 0 && wrong == 0 && answers && t_.serverErrors == 0 &&
                  t_.malformedAccepted == 0 && (!o_.checkFlat || flat);
  return ok ? 0 : 1;
}

std::optional<Options> parseOptions(const std::vector<std::string>& args) {
  Options o;
  std::vector<std::string> positional;
  for (std::size_t i = 0; i < args.size(); ++i) {
    const std::string& a = args[i];
    const auto next = [&]() { return i + 1 < args.size() ? std::atof(args[++i].c_str()) : -1.0; };
    if (a == "--duration-s") {
      o.durationSeconds = next();
    } else if (a == "--warmup-s") {
      o.warmupSeconds = next();
    } else if (a == "--window-s") {
      o.windowSeconds = next();
    } else if (a == "--workers") {
      o.workers = static_cast<int>(next());
    } else if (a == "--queue") {
      o.queue = static_cast<int>(next());
    } else if (a == "--width") {
      o.width = static_cast<int>(next());
    } else if (a == "--height") {
      o.height = static_cast<int>(next());
    } else if (a == "--compare") {
      o.compare = static_cast<int>(next());
    } else if (a == "--check-flat") {
      o.checkFlat = true;
    } else {
      positional.push_back(a);
    }
  }
  if (positional.size() != 2 || !(o.durationSeconds > 0.0) || !(o.windowSeconds > 0.0) ||
      o.warmupSeconds < 0.0 || o.workers < 1 || o.queue < 0 || o.width < 1 || o.width > 4096 ||
      o.height < 1 || o.height > 4096 || o.compare < 0 || o.compare > 100) {
    return std::nullopt;
  }
  o.pbdam = positional[0];
  o.dataset = positional[1];
  return o;
}

int run(const std::vector<std::string>& args) {
  const std::optional<Options> o = parseOptions(args);
  if (!o) {
    std::fprintf(stderr,
                 "usage: pbdam_serve_soak PBDAM_EXE DATASET [--duration-s 1800] [--warmup-s 60] "
                 "[--window-s 60] [--workers 2] [--queue 4] [--width 320] [--height 240] "
                 "[--compare 4] [--check-flat]\n");
    return 2;
  }
  ::signal(SIGPIPE, SIG_IGN);
  const Server started =
      startServer(o->pbdam, o->dataset,
                  {"--workers", std::to_string(o->workers), "--queue", std::to_string(o->queue)});
  if (started.pid < 0) return 1;
  std::printf("%s", started.startLine.c_str());
  std::printf(
      "soak: %.0f s (warm-up %.0f s, windows of %.0f s), %dx%d frames, --workers %d "
      "--queue %d\n",
      o->durationSeconds, o->warmupSeconds, o->windowSeconds, o->width, o->height, o->workers,
      o->queue);
  Soak soak(*o, started.port, started.pid);
  return soak.run();
}

}  // namespace

int main(int argc, char** argv) {
  try {
    return run(std::vector<std::string>(argv + 1, argv + argc));
  } catch (const std::exception& e) {
    std::fprintf(stderr, "pbdam_serve_soak: %s\n", e.what());
  }
  return 1;
}
