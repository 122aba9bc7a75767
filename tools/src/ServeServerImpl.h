// What the two sources of `pbdam serve`'s HTTP side share (ServeServer.h): the served
// generation, the server's state (FrameServer::Impl) with its endpoints, and the JSON replies.
// ServeServer.cpp routes requests and runs the server; ServeTerrainEndpoints.cpp answers
// /frame, /height, /los and /viewshed from the served generation.
#pragma once

#include <httplib.h>

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <map>
#include <memory>
#include <mutex>
#include <nlohmann/json.hpp>
#include <span>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "ServeQueries.h"
#include "ServeRenderPool.h"
#include "ServeServer.h"
#include "pbdam/formats/Result.h"
#include "pbdam/streaming/MappedDataset.h"

namespace pbdam::tools {
namespace serve_internal {

using Clock = std::chrono::steady_clock;
using Json = nlohmann::ordered_json;

/// What is served: one mapping of the dataset and the render pool (contexts, GPU cache) drawing
/// it. Requests hold it through shared_ptr; the last one to let go destroys it — the pool first
/// (members go in reverse order), then the mapping.
// RenderPool's destructor joins its threads, which throws only on misuse (joining itself).
// NOLINTNEXTLINE(bugprone-exception-escape): see above
struct Generation final {
  std::unique_ptr<streaming::MappedDataset> dataset;
  std::unique_ptr<RenderPool> pool;
  std::unique_ptr<ServeQueries> queries;  ///< on the pool's context: destroyed before it
  Json info;
  std::uint64_t number = 1;  ///< 1 at start, +1 per successful reload
};

/// Answers with `body` as JSON and `status`; never cached.
void sendJson(httplib::Response& res, int status, const Json& body);
/// Answers `status` with the JSON error body every refusal has: status, reason and `message`.
void sendError(httplib::Response& res, int status, const std::string& message);
/// HTTP status for a library error: the client's fault (4xx) or ours (5xx).
int statusFor(const formats::Error& error);

}  // namespace serve_internal

struct FrameServer::Impl {
  using Clock = serve_internal::Clock;
  using Json = serve_internal::Json;
  using Generation = serve_internal::Generation;

  ServeOptions options;
  std::string directory;
  httplib::Server http;
  Clock::time_point started = Clock::now();
  std::uint32_t httpThreads = 0;
  int port = 0;

  std::atomic<bool> stopRequested{false};
  std::atomic<bool> running{false};
  std::mutex stopMutex;
  std::condition_variable stopWake;

  mutable std::mutex countersMutex;
  std::map<int, std::uint64_t> responsesByStatus;
  std::map<std::string, std::uint64_t> requestsByPath;
  std::uint64_t requests = 0;
  std::atomic<std::uint64_t> served{0};

  // The served generation, swapped by reload(); reloads run one at a time.
  mutable std::mutex generationMutex;
  std::shared_ptr<Generation> generation;
  std::uint64_t reloads = 0;
  std::uint64_t failedReloads = 0;
  std::string lastReloadError;
  std::mutex reloadMutex;

  // /healthz's last table check: its generation, time and findings.
  mutable std::mutex healthMutex;
  std::uint64_t tablesCheckedGeneration = 0;
  Clock::time_point tablesCheckedAt;
  std::vector<std::string> tableProblems;

  std::shared_ptr<Generation> current() const {
    const std::lock_guard<std::mutex> lock(generationMutex);
    return generation;
  }
  formats::Result<std::uint64_t> reload();

  /// The one method an endpoint answers (GET answers HEAD too); any other gets a 405.
  enum class Method { Get, Post };
  /// Answers one request on behalf of the server.
  using Handler = void (*)(Impl& server, const httplib::Request& req, httplib::Response& res);
  /// One endpoint of the server.
  struct Route final {
    std::string_view path;
    Method method;
    Handler handle;
  };
  /// Every endpoint, in the order routeSummary() names them: what routes() registers, what
  /// answers 405 rather than 404 for other methods, and the paths /stats counts requests by.
  static std::span<const Route> routeTable() noexcept;
  /// The endpoint at exactly `path`; nullptr when there is none.
  static const Route* findRoute(std::string_view path) noexcept;
  /// A route's handler: calls the member function `Handle` of the server.
  template <auto Handle>
  static void answer(Impl& server, const httplib::Request& req, httplib::Response& res) {
    (server.*Handle)(req, res);
  }

  void routes();
  void handleViewer(const httplib::Request& req, httplib::Response& res) const;
  void handleFrame(const httplib::Request& req, httplib::Response& res) const;
  void handleHeight(const httplib::Request& req, httplib::Response& res) const;
  void handleLos(const httplib::Request& req, httplib::Response& res) const;
  void handleViewshed(const httplib::Request& req, httplib::Response& res) const;
  void handleInfo(const httplib::Request& req, httplib::Response& res) const;
  void handleStats(const httplib::Request& req, httplib::Response& res) const;
  void handleHealth(const httplib::Request& req, httplib::Response& res);
  void handleReload(const httplib::Request& req, httplib::Response& res);
  std::pair<int, Json> healthJson();
  Json statsJson() const;
  static int retryAfterSeconds(const RenderPool& pool);
};

}  // namespace pbdam::tools
