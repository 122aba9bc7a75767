// `pbdam serve DIR`: exact-mode frames over HTTP with a web viewer (docs/architecture.md "What
// pbdam is"). The command line, the start-up line, graceful shutdown and reload: SIGTERM/SIGINT
// and SIGHUP are taken by a signal thread (sigtimedwait; blocked in every other thread). SIGTERM
// and SIGINT stop the listener; the requests already accepted are answered before the process
// exits with 0. SIGHUP maps the dataset directory again and serves it (FrameServer::reload); a
// broken one is refused with a line on stderr and the old one goes on being served.
#include <malloc.h>
#include <signal.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <iostream>
#include <memory>
#include <string>
#include <thread>

#include "Commands.h"
#include "ExaggerationOption.h"
#include "MorphOption.h"
#include "ServeServer.h"
#include "pbdam/formats/GuardedCopy.h"
#include "pbdam/gpu/TerrainRenderer.h"

using namespace pbdam::formats;

namespace pbdam::tools {
namespace {

struct ServeCliOptions {
  std::string dir;
  ServeOptions server;
  MorphCliOptions morph;
  std::string atmosphere = "on";
  bool quiet = false;
};

int badInput(const std::string& message) {
  std::cerr << "pbdam: " << message << "\n";
  return kExitBadInput;
}

int runServe(const ServeCliOptions& c) {
  ServeOptions o = c.server;
  o.morph = c.morph.morph == "on";
  o.morphRange = c.morph.range;
  if (o.port < 0 || o.port > 65535)
    return badInput("--port must be in 0..65535 (0: any free port)");
  if (o.workers < 1 || o.workers > 64) return badInput("--workers must be in 1..64");
  if (o.queueCapacity > 4096) return badInput("--queue must be in 0..4096");
  if (o.framesInFlight < 1 || o.framesInFlight > gpu::TerrainRenderer::kMaxFramesInFlight) {
    return badInput("--frames-in-flight must be in 1.." +
                    std::to_string(gpu::TerrainRenderer::kMaxFramesInFlight));
  }
  if (!std::isfinite(o.gpuCacheMiB) || o.gpuCacheMiB <= 0.0 || o.gpuCacheMiB > 1048576.0) {
    return badInput("--gpu-cache-mib (--gpu-cache-mb) must be a positive number of MiB");
  }
  if (!std::isfinite(o.memoryBudgetMiB) || o.memoryBudgetMiB < 0.0 ||
      o.memoryBudgetMiB > 16777216.0) {
    return badInput("--memory-budget-mib must be a number of MiB >= 0 (0: the cgroup's limit)");
  }
  if (!std::isfinite(o.deadlineSeconds) || o.deadlineSeconds <= 0.0 || o.deadlineSeconds > 3600.0) {
    return badInput("--deadline-s must be in (0, 3600] seconds");
  }
  if (o.bindAddress.empty()) return badInput("--bind must name a local address");
  if (c.morph.morph != "on" && c.morph.morph != "off") {
    return badInput("--morph '" + c.morph.morph + "': expected on or off");
  }
  if (auto r = checkExaggeration(o.exaggeration); !r) return reportError(r.error());
  if (c.atmosphere != "on" && c.atmosphere != "off") {
    return badInput("--atmosphere '" + c.atmosphere + "': expected on or off");
  }
  o.atmosphere = c.atmosphere == "on";
  if (!std::isfinite(c.morph.range) || c.morph.range <= 0.0) {
    return badInput("--morph-range must be a positive fraction of the tolerance");
  }

  // Before any thread exists (TBB, lavapipe, httplib, the render contexts), so that every
  // thread inherits the mask and only the signal thread below sees SIGTERM/SIGINT.
  sigset_t stopSignals;
  sigemptyset(&stopSignals);
  sigaddset(&stopSignals, SIGTERM);
  sigaddset(&stopSignals, SIGINT);
  sigaddset(&stopSignals, SIGHUP);
  pthread_sigmask(SIG_BLOCK, &stopSignals, nullptr);
  ::signal(SIGPIPE, SIG_IGN);  // a client that hangs up is a failed write, not a dead server
  // Few malloc arenas. By default glibc gives up to 8 per core, and with dozens of HTTP threads
  // each arena comes to keep its own free blocks between frames: over a soak, anonymous memory
  // kept growing through fragmentation while the heap in use and the cache stayed flat. With two
  // arenas (or one per render context) it levels off, for about 3% of the request rate
  // (docs/decisions.md "Server"). Set before any thread exists: arenas are made as threads
  // first allocate.
  ::mallopt(M_ARENA_MAX, std::max(2, static_cast<int>(o.workers)));
  // Every read of the dataset is a guarded copy (an unreadable page fails one request); a fault
  // anywhere else is a bug, and crashes with its core dump rather than a tidy exit.
  reportUnreadableMappingsAndExit(-1);

  auto server = FrameServer::create(c.dir, o);
  if (!server) return reportError(server.error());
  auto port = (*server)->bind();
  if (!port) return reportError(port.error());
  if (!c.quiet) {
    std::printf(
        "pbdam serve: http://%s:%d/ (dataset %s; %u render contexts on %s, queue %u, GPU cache "
        "%.0f MiB shared by them, deadline %.1f s)\n",
        o.bindAddress.find(':') != std::string::npos ? ("[" + o.bindAddress + "]").c_str()
                                                     : o.bindAddress.c_str(),
        *port, c.dir.c_str(), o.workers, (*server)->deviceName().c_str(), o.queueCapacity,
        o.gpuCacheMiB, o.deadlineSeconds);
    std::fflush(stdout);
  }

  std::atomic<bool> finished{false};
  std::atomic<int> caught{0};
  FrameServer* raw = server->get();
  std::thread signals([&] {
    const timespec poll{0, 200'000'000};
    while (!finished.load()) {
      const int sig = sigtimedwait(&stopSignals, nullptr, &poll);
      if (sig == SIGHUP) {
        const Result<void> reloaded = raw->reload();
        if (!reloaded) {
          std::fprintf(stderr, "pbdam serve: SIGHUP: %s\n", reloaded.error().message.c_str());
        } else if (!c.quiet) {
          std::printf("pbdam serve: SIGHUP: reloaded %s\n", c.dir.c_str());
          std::fflush(stdout);
        }
        continue;
      }
      if (sig == SIGTERM || sig == SIGINT) {
        caught = sig;
        raw->stop();
        return;
      }
    }
  });
  Result<void> ran = (*server)->run();
  finished = true;
  signals.join();
  if (!ran) return reportError(ran.error());
  if (!c.quiet) {
    std::printf("pbdam serve: stopped%s after %llu requests\n",
                caught == SIGTERM  ? " (SIGTERM)"
                : caught == SIGINT ? " (SIGINT)"
                                   : "",
                static_cast<unsigned long long>((*server)->requestsServed()));
    std::fflush(stdout);
  }
  return kExitOk;
}

}  // namespace

void addServeCommand(CLI::App& app, CommandStatus& status) {
  auto o = std::make_shared<ServeCliOptions>();
  CLI::App* serve = app.add_subcommand(
      "serve",
      "Serve exact-mode frames over HTTP (" + FrameServer::routeSummary() +
          "): GET /frame?lat=&lon=&alt=[&heading=&pitch=&roll=&width=&height=&fov=&tolerance="
          "&morph=on|off&format=png|jpeg] draws a frame (PNG/JPEG), / is a web viewer, the "
          "others answer JSON (/viewshed also GeoTIFF or PNG). SIGTERM/SIGINT stop it after "
          "the requests in flight; SIGHUP or POST /admin/reload (from loopback only) serves the "
          "dataset rebuilt in DIR without a restart");
  serve->add_option("DIR", o->dir, "Dataset directory (pbdam build --out)")->required();
  serve->add_option("--bind", o->server.bindAddress, "Address to listen on (loopback by default)")
      ->capture_default_str();
  serve->add_option("--port", o->server.port, "TCP port; 0 picks a free one (printed)")
      ->capture_default_str();
  serve
      ->add_option("--workers", o->server.workers,
                   "Render contexts: renderers drawing in parallel over one Vulkan device and "
                   "one mapping of the dataset")
      ->capture_default_str();
  serve
      ->add_option("--queue", o->server.queueCapacity,
                   "Frame requests that may wait for a busy render context; beyond that: 503 "
                   "with Retry-After")
      ->capture_default_str();
  serve->add_option("--frames-in-flight", o->server.framesInFlight, kFramesInFlightHelp)
      ->capture_default_str();
  serve
      ->add_option("--gpu-cache-mib,--gpu-cache-mb", o->server.gpuCacheMiB,
                   "GPU cache budget in MiB: one cache (LRU, pools) shared by every render "
                   "context. --gpu-cache-mb is its former spelling (also MiB)")
      ->capture_default_str();
  serve
      ->add_option("--memory-budget-mib", o->server.memoryBudgetMiB,
                   "Memory the server may use in MiB (0: the memory cgroup's limit, if any): on a "
                   "CPU device the GPU cache is lowered to leave room for the dataset's pages; "
                   "below what it needs it refuses to start")
      ->capture_default_str();
  serve
      ->add_option("--deadline-s", o->server.deadlineSeconds,
                   "Per-request deadline for /frame (queueing and drawing): 503 when missed")
      ->capture_default_str();
  serve->add_option("--device", o->server.device, kDeviceOptionHelp);
  addMorphOptions(*serve, o->morph, false);
  addExaggerationOption(*serve, o->server.exaggeration);
  serve
      ->add_option("--atmosphere", o->atmosphere,
                   "on: load the planet's atmosphere (Earth, Mars; its tables computed once per "
                   "machine) for the requests that ask for it; off: none, atmosphere=on refused")
      ->capture_default_str();
  serve->add_flag("--log", o->server.logRequests, "One line per request on stdout");
  serve->add_flag("--quiet", o->quiet, "No start-up and shutdown lines");
  serve->callback([o, &status] { status.exitCode = runServe(*o); });
}

}  // namespace pbdam::tools
