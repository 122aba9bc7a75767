// The HTTP side of `pbdam serve` (docs/architecture.md "What pbdam is"): cpp-httplib (Debian's
// libcpp-httplib) routes the endpoints of one route table (FrameServer::routeSummary() names
// them; the embedded viewer page is GET /), turns every bad request into a 4xx with a JSON body,
// and answers overload with 503 + Retry-After. Frames come from a RenderPool over one mapping of
// the dataset: together they are the served *generation*, which reload() replaces by a new one
// over the files now in the directory while requests in flight finish on the old one. A dataset
// whose files become unreadable (truncated in place, a failing disk) fails the frames that need
// them with a 500 naming file and offset; the server goes on, and /healthz says "degraded".
// Thread-safety: stop() and reload() may be called from any thread (the signal thread); the rest
// from the thread that owns the server.
#pragma once

#include <cstdint>
#include <memory>
#include <string>

#include "ServeRenderPool.h"
#include "pbdam/formats/Result.h"

namespace pbdam::tools {

struct ServeOptions final {
  std::string bindAddress = "127.0.0.1";
  int port = 8080;  ///< 0: any free port (the bound one is returned by bind())
  std::uint32_t workers = 2;
  std::uint32_t queueCapacity = 8;
  std::uint32_t framesInFlight = 2;  ///< per render context (RenderPoolOptions)
  double gpuCacheMiB = 256.0;
  /// Memory the server may use in MiB; 0: the memory cgroup's limit, if any (MemoryBudget.h).
  double memoryBudgetMiB = 0.0;
  double deadlineSeconds = 10.0;  ///< per /frame request: queueing and drawing together
  std::string device;             ///< Vulkan device selector (ContextOptions::device)
  bool logRequests = false;       ///< one line per request on stdout
  /// The geomorph of frames whose request does not say (morph=on|off), and its window
  /// (RefinementOptions::morphRange when on; at most the dataset's error margin).
  bool morph = true;
  double morphRange = 0.25;
  /// Vertical exaggeration of every frame (0 < F <= 100): fixed for the server, as the render
  /// contexts' shared cache holds patches decoded under it; a request's exaggeration= must
  /// be this one.
  double exaggeration = 1.0;
  /// Whether the contexts load the planet's atmosphere (Earth's, Mars's) at start: requests
  /// then ask for it (atmosphere=, or a real sun with auto). Off, atmosphere=on is refused.
  bool atmosphere = true;
};

class FrameServer final {
 public:
  /// Maps the dataset at `directory` and creates the render contexts. Errors as
  /// MappedDataset::open and RenderPool::create.
  static formats::Result<std::unique_ptr<FrameServer>> create(const std::string& directory,
                                                              const ServeOptions& options);
  ~FrameServer();
  FrameServer(const FrameServer&) = delete;
  FrameServer& operator=(const FrameServer&) = delete;

  /// Binds the listening socket; returns the port (the chosen one for port 0). IoError naming
  /// the address when it cannot be bound.
  formats::Result<int> bind();
  /// Serves until stop(): returns once the listener is closed and every accepted connection
  /// has been answered (in-flight frames are finished, not dropped).
  formats::Result<void> run();
  /// Stops accepting connections; run() then returns after the in-flight requests. Safe from
  /// any thread, any number of times.
  void stop();
  /// Maps the dataset directory again (a rebuilt dataset) and serves it from here on with a new
  /// render pool and GPU cache: requests in flight finish on the old dataset, which is unmapped
  /// once the last of them is answered; nothing cached from it is drawn again. Errors (the new
  /// dataset is broken or missing, as MappedDataset::open and RenderPool::create) keep the old
  /// one served and are remembered for /healthz and /stats. One reload runs at a time.
  formats::Result<void> reload();
  /// The render pool's device, for the start-up line.
  std::string deviceName() const;
  /// Requests answered so far.
  std::uint64_t requestsServed() const noexcept;
  /// The server's endpoints by method, as the 404 message and `pbdam serve --help` name them:
  /// "GET /, /frame, …; POST /admin/reload".
  static std::string routeSummary();

 private:
  struct Impl;
  explicit FrameServer(std::unique_ptr<Impl> impl) noexcept;
  std::unique_ptr<Impl> impl_;
};

}  // namespace pbdam::tools
