// The HTTP side of `pbdam serve` (ServeServer.h): the bounded connection pool, the route table
// and its JSON refusals, /info, /stats, /healthz (with its checks of the files), the viewer page,
// reloads, and the server's start and stop. The terrain endpoints are ServeTerrainEndpoints.cpp.
#include "ServeServer.h"

#include <httplib.h>
#include <sys/stat.h>

#include <array>
#include <atomic>
#include <cerrno>
#include <chrono>
#include <condition_variable>
#include <cstdio>
#include <cstring>
#include <deque>
#include <functional>
#include <mutex>
#include <nlohmann/json.hpp>
#include <span>
#include <string>
#include <string_view>
#include <thread>
#include <vector>

#include "ServeQueries.h"
#include "ServeRequest.h"
#include "ServeServerImpl.h"
#include "ServeStats.h"
#include "ServeViewerHtml.h"
#include "pbdam/formats/DatasetFormat.h"
#include "pbdam/formats/GuardedCopy.h"
#include "pbdam/streaming/MappedDataset.h"
#include "pbdam/streaming/MemoryBudget.h"
#include "pbdam/streaming/ProcessMemory.h"

using namespace pbdam::formats;
using namespace pbdam::runtime;
using namespace pbdam::streaming;

namespace pbdam::tools {

using namespace serve_internal;

namespace {

/// httplib's connection pool with a bound: at most `maxPending` accepted connections wait for a
/// thread; beyond that the accept loop blocks, so further clients wait in the kernel's listen
/// backlog instead of in our memory. (httplib's own ThreadPool queues without limit.)
class BoundedTaskQueue final : public httplib::TaskQueue {
 public:
  BoundedTaskQueue(std::size_t threads, std::size_t maxPending) : maxPending_(maxPending) {
    for (std::size_t i = 0; i < threads; ++i) threads_.emplace_back([this] { work(); });
  }
  BoundedTaskQueue(const BoundedTaskQueue&) = delete;
  BoundedTaskQueue& operator=(const BoundedTaskQueue&) = delete;
  ~BoundedTaskQueue() override = default;

  void enqueue(std::function<void()> fn) override {
    std::unique_lock<std::mutex> lock(mutex_);
    room_.wait(lock, [&] { return jobs_.size() < maxPending_ || shutdown_; });
    jobs_.push_back(std::move(fn));
    lock.unlock();
    ready_.notify_one();
  }

  /// Runs every job already queued, then joins the threads.
  void shutdown() override {
    {
      const std::lock_guard<std::mutex> lock(mutex_);
      shutdown_ = true;
    }
    ready_.notify_all();
    room_.notify_all();
    for (std::thread& t : threads_) t.join();
  }

 private:
  void work() {
    for (;;) {
      std::function<void()> fn;
      {
        std::unique_lock<std::mutex> lock(mutex_);
        ready_.wait(lock, [&] { return !jobs_.empty() || shutdown_; });
        if (jobs_.empty()) return;  // shut down and drained
        fn = std::move(jobs_.front());
        jobs_.pop_front();
      }
      room_.notify_one();
      fn();
    }
  }

  const std::size_t maxPending_;
  std::mutex mutex_;
  std::condition_variable ready_;
  std::condition_variable room_;
  std::deque<std::function<void()>> jobs_;
  bool shutdown_ = false;
  std::vector<std::thread> threads_;
};

const char* reasonPhrase(int status) {
  switch (status) {
    case 400:
      return "Bad Request";
    case 403:
      return "Forbidden";
    case 404:
      return "Not Found";
    case 405:
      return "Method Not Allowed";
    case 408:
      return "Request Timeout";
    case 413:
      return "Payload Too Large";
    case 414:
      return "URI Too Long";
    case 416:
      return "Range Not Satisfiable";
    case 422:
      return "Unprocessable Content";
    case 500:
      return "Internal Server Error";
    case 503:
      return "Service Unavailable";
    default:
      return status >= 500 ? "Server Error" : "Client Error";
  }
}

}  // namespace

void serve_internal::sendJson(httplib::Response& res, int status, const Json& body) {
  res.status = status;
  res.set_header("Cache-Control", "no-store");
  res.set_content(body.dump() + "\n", "application/json");
}

void serve_internal::sendError(httplib::Response& res, int status, const std::string& message) {
  Json j;
  j["status"] = status;
  j["error"] = reasonPhrase(status);
  j["message"] = message;
  sendJson(res, status, j);
}

int serve_internal::statusFor(const Error& error) {
  switch (error.code) {
    case ErrorCode::InvalidArgument:
      return 400;
    case ErrorCode::NotFound:
      return 404;
    default:
      return 500;
  }
}

namespace {

/// Whether a peer address is this machine's loopback (IPv4 127/8, IPv6 ::1, or IPv4-mapped).
bool isLoopback(const std::string& address) {
  return address.starts_with("127.") || address == "::1" || address.starts_with("::ffff:127.");
}

/// GET /info of a generation: the dataset and the server's settings.
Json makeInfo(const MappedDataset& dataset, const ServeOptions& options,
              const std::string& device) {
  const DatasetView& view = dataset.view();
  const Manifest& m = view.manifest();
  std::uint64_t nodes = 0;
  for (int f = 0; f < 6; ++f) nodes += view.face(f).header().nodeCount;
  Json info;
  info["dataset"] = dataset.directory().filename().string();
  info["planet"] = m.planetSpec;
  info["equatorial_radius_m"] = m.equatorialRadiusMeters;
  info["flattening"] = m.flattening;
  info["source_dem"] = m.sourceDem;
  info["min_height_m"] = m.minHeightMeters;
  info["max_height_m"] = m.maxHeightMeters;
  info["lattice_cells"] = m.latticeCells;
  info["depth"] = m.depth;
  info["patches"] = nodes;
  info["texture_levels"] = m.textureLevels;
  info["texture_format"] = m.textureFormat;
  info["texture_source"] = m.textureSource;
  info["bytes"] = dataset.bytes();
  info["frame"] = {{"max_side_px", kMaxFrameSidePixels},
                   {"tolerance_px", {kMinTolerancePixels, kMaxTolerancePixels}},
                   {"defaults",
                    {{"heading", 0},
                     {"pitch", -90},
                     {"roll", 0},
                     {"width", 640},
                     {"height", 480},
                     {"fov", 60},
                     {"tolerance", 3},
                     {"morph", options.morph ? "on" : "off"},
                     {"format", "png"}}},
                   {"morph_range", options.morphRange},
                   {"exaggeration", options.exaggeration},
                   {"atmosphere", options.atmosphere}};
  info["server"] = {
      {"contexts", options.workers},           {"frames_in_flight", options.framesInFlight},
      {"queue", options.queueCapacity},        {"gpu_cache_mib", options.gpuCacheMiB},
      {"deadline_s", options.deadlineSeconds}, {"device", device}};
  return info;
}

Result<std::shared_ptr<Generation>> openGeneration(const std::string& directory,
                                                   const ServeOptions& options,
                                                   std::uint64_t number) {
  auto generation = std::make_shared<Generation>();
  generation->number = number;
  auto dataset =
      MappedDataset::open(directory, faceOptionsFor(memoryLimitOf(options.memoryBudgetMiB)));
  if (!dataset) return std::move(dataset).error();
  if (auto r = checkMorphRange((*dataset)->view(), options.morphRange); !r) return r.error();
  generation->dataset = std::move(*dataset);
  RenderPoolOptions poolOptions;
  poolOptions.workers = options.workers;
  poolOptions.framesInFlight = options.framesInFlight;
  poolOptions.queueCapacity = options.queueCapacity;
  poolOptions.gpuCacheBytes = static_cast<std::uint64_t>(options.gpuCacheMiB * 1048576.0);
  poolOptions.memoryBudgetMiB = options.memoryBudgetMiB;
  poolOptions.device = options.device;
  poolOptions.exaggeration = options.exaggeration;
  poolOptions.atmosphere = options.atmosphere;
  auto pool = RenderPool::create(*generation->dataset, poolOptions);
  if (!pool) return std::move(pool).error();
  generation->pool = std::move(*pool);
  generation->queries =
      std::make_unique<ServeQueries>(generation->dataset->view(), generation->pool->context(),
                                     std::chrono::duration<double>(options.deadlineSeconds));
  generation->info = makeInfo(*generation->dataset, options, generation->pool->deviceName());
  return generation;
}

/// What /healthz found wrong with the files of a generation (empty: nothing), and files that
/// were replaced on disk since they were mapped (a rebuild waiting for a reload).
struct FileCheck final {
  std::vector<std::string> problems;
  std::vector<std::string> replaced;
};

/// Sizes of every face file against manifest.json, through the path (cheap: one stat each).
/// A path that names another file than the one mapped was replaced by a rebuild: noted, not a
/// problem (the mapping still holds the old file).
void checkFileSizes(const MappedDataset& dataset, FileCheck& check) {
  const Manifest& m = dataset.view().manifest();
  for (int f = 0; f < 6; ++f) {
    const MappedFile& file = dataset.faceFile(f);
    const std::string name = m.faces[static_cast<std::size_t>(f)].file;
    struct stat st {};
    if (::stat(file.path().c_str(), &st) != 0) {
      check.problems.push_back(name + ": missing (" + std::strerror(errno) + ")");
      continue;
    }
    const auto [device, inode] = file.fileIdentity();
    if (static_cast<std::uint64_t>(st.st_dev) != device ||
        static_cast<std::uint64_t>(st.st_ino) != inode) {
      check.replaced.push_back(name);
      continue;
    }
    const auto expected = m.faces[static_cast<std::size_t>(f)].bytes;
    if (static_cast<std::uint64_t>(st.st_size) != expected) {
      check.problems.push_back(name + ": " + std::to_string(st.st_size) +
                               " bytes, manifest.json says " + std::to_string(expected) +
                               (static_cast<std::uint64_t>(st.st_size) < expected
                                    ? " (truncated in place)"
                                    : " (grown in place)"));
    }
  }
}

/// Header and table checksums of every face, read again through the mapping (guarded): a
/// failing disk or bytes rewritten in place since the dataset was opened. Reads the tables —
/// megabytes — so /healthz runs it at most every kTableCheckSeconds.
void checkTables(const MappedDataset& dataset, FileCheck& check) {
  for (int f = 0; f < 6; ++f) {
    const MappedFile& file = dataset.faceFile(f);
    const FaceView& face = dataset.view().face(f);
    const FaceHeader& h = face.header();
    std::array<std::byte, kFaceHeaderBytes> header{};
    if (auto r = file.read(0, header); !r) {
      check.problems.push_back(r.error().message);
      continue;
    }
    if (auto r = decodeFaceHeader(header, file.size(), face.context()); !r) {
      check.problems.push_back(r.error().message);
      continue;
    }
    auto nodes = crc32Mapped(file.bytes(), h.nodeTableOffset, h.nodeCount * kNodeRecordBytes,
                             face.context());
    auto textures = crc32Mapped(file.bytes(), h.textureTableOffset,
                                h.textureNodeCount * kTextureRecordBytes, face.context());
    if (!nodes) {
      check.problems.push_back(nodes.error().message);
    } else if (*nodes != h.nodeTableCrc) {
      check.problems.push_back(face.context() + ": node table checksum differs from its header");
    }
    if (!textures) {
      check.problems.push_back(textures.error().message);
    } else if (*textures != h.textureTableCrc) {
      check.problems.push_back(face.context() + ": texture table checksum differs from its header");
    }
  }
}

constexpr double kTableCheckSeconds = 10.0;

}  // namespace

Result<std::uint64_t> FrameServer::Impl::reload() {
  const std::lock_guard<std::mutex> reloading(reloadMutex);
  std::shared_ptr<Generation> old = current();
  auto next = openGeneration(directory, options, old->number + 1);
  const std::lock_guard<std::mutex> lock(generationMutex);
  if (!next) {
    ++failedReloads;
    lastReloadError = next.error().message;
    Error error = std::move(next).error();
    error.message = "reload failed, still serving the dataset loaded before: " + error.message;
    return error;
  }
  generation = std::move(*next);
  ++reloads;
  lastReloadError.clear();
  // `old` goes when the requests still drawing from it have been answered (the last one
  // destroys it), or here, after the lock, when none are.
  return generation->number;
}

void FrameServer::Impl::handleReload(const httplib::Request& req, httplib::Response& res) {
  if (!isLoopback(req.remote_addr)) {
    return sendError(
        res, 403,
        "POST /admin/reload is accepted only from loopback (" + req.remote_addr + " is not)");
  }
  if (auto r = expectNoParams(req.params); !r) return sendError(res, 400, r.error().message);
  auto number = reload();
  if (!number) {
    const ErrorCode code = number.error().code;
    const bool badDataset = code == ErrorCode::CorruptData || code == ErrorCode::NotFound ||
                            code == ErrorCode::UnsupportedFormat;
    return sendError(res, badDataset ? 422 : 500, number.error().message);
  }
  sendJson(res, 200, {{"status", "reloaded"}, {"generation", *number}, {"dataset", directory}});
}

std::pair<int, Json> FrameServer::Impl::healthJson() {
  if (stopRequested) return {503, {{"status", "stopping"}}};
  const std::shared_ptr<Generation> g = current();
  FileCheck check;
  checkFileSizes(*g->dataset, check);
  {
    // The table checksums read megabytes: at most every kTableCheckSeconds per generation.
    const std::lock_guard<std::mutex> lock(healthMutex);
    const auto now = Clock::now();
    if (tablesCheckedGeneration != g->number ||
        std::chrono::duration<double>(now - tablesCheckedAt).count() >= kTableCheckSeconds) {
      FileCheck tables;
      checkTables(*g->dataset, tables);
      tableProblems = std::move(tables.problems);
      tablesCheckedGeneration = g->number;
      tablesCheckedAt = now;
    }
    check.problems.insert(check.problems.end(), tableProblems.begin(), tableProblems.end());
  }
  Json j;
  j["status"] = check.problems.empty() ? "ok" : "degraded";
  if (!check.problems.empty()) j["reasons"] = check.problems;
  j["dataset"] = directory;
  j["generation"] = g->number;
  if (!check.replaced.empty()) {
    j["replaced_on_disk"] = check.replaced;  // a rebuild: POST /admin/reload or SIGHUP serves it
  }
  {
    const std::lock_guard<std::mutex> lock(generationMutex);
    if (!lastReloadError.empty()) j["last_reload_error"] = lastReloadError;
  }
  return {check.problems.empty() ? 200 : 503, j};
}

Json FrameServer::Impl::statsJson() const {
  const std::shared_ptr<Generation> g = current();
  const RenderPool* pool = g->pool.get();
  const RenderPoolStats s = pool->stats();
  ServeCounters counters;
  counters.uptimeSeconds = std::chrono::duration<double>(Clock::now() - started).count();
  {
    const std::lock_guard<std::mutex> lock(generationMutex);
    counters.directory = directory;
    counters.generation = g->number;
    counters.reloads = reloads;
    counters.failedReloads = failedReloads;
    counters.lastReloadError = lastReloadError;
  }
  {
    const std::lock_guard<std::mutex> lock(countersMutex);
    counters.requests = requests;
    counters.responsesByStatus = responsesByStatus;
    counters.requestsByPath = requestsByPath;
    counters.httpThreads = httpThreads;
    counters.rssBytes = residentSetBytes();
  }
  return serveStatsJson(counters, s, g->queries->stats(), options, pool->deviceName());
}

std::span<const FrameServer::Impl::Route> FrameServer::Impl::routeTable() noexcept {
  static constexpr auto kRoutes = std::to_array<Route>({
      {"/", Method::Get, &answer<&Impl::handleViewer>},
      {"/frame", Method::Get, &answer<&Impl::handleFrame>},
      {"/height", Method::Get, &answer<&Impl::handleHeight>},
      {"/los", Method::Get, &answer<&Impl::handleLos>},
      {"/viewshed", Method::Get, &answer<&Impl::handleViewshed>},
      {"/info", Method::Get, &answer<&Impl::handleInfo>},
      {"/stats", Method::Get, &answer<&Impl::handleStats>},
      {"/healthz", Method::Get, &answer<&Impl::handleHealth>},
      {"/admin/reload", Method::Post, &answer<&Impl::handleReload>},
  });
  return kRoutes;
}

const FrameServer::Impl::Route* FrameServer::Impl::findRoute(std::string_view path) noexcept {
  for (const Route& route : routeTable()) {
    if (route.path == path) return &route;
  }
  return nullptr;
}

std::string FrameServer::routeSummary() {
  std::string summary;
  for (const Impl::Method method : {Impl::Method::Get, Impl::Method::Post}) {
    std::string paths;
    for (const Impl::Route& route : Impl::routeTable()) {
      if (route.method != method) continue;
      paths += paths.empty() ? (method == Impl::Method::Get ? "GET " : "POST ") : ", ";
      paths += route.path;
    }
    if (paths.empty()) continue;
    if (!summary.empty()) summary += "; ";
    summary += paths;
  }
  return summary;
}

void FrameServer::Impl::handleViewer(const httplib::Request&, httplib::Response& res) const {
  res.set_header("Cache-Control", "no-store");
  res.set_header("Content-Security-Policy",
                 "default-src 'none'; img-src 'self' blob: data:; connect-src 'self'; "
                 "script-src 'unsafe-inline'; style-src 'unsafe-inline'");
  res.set_content(reinterpret_cast<const char*>(kViewerHtml), kViewerHtmlSize,
                  "text/html; charset=utf-8");
}

void FrameServer::Impl::handleInfo(const httplib::Request& req, httplib::Response& res) const {
  if (auto r = expectNoParams(req.params); !r) return sendError(res, 400, r.error().message);
  sendJson(res, 200, current()->info);
}

void FrameServer::Impl::handleStats(const httplib::Request& req, httplib::Response& res) const {
  if (auto r = expectNoParams(req.params); !r) return sendError(res, 400, r.error().message);
  sendJson(res, 200, statsJson());
}

void FrameServer::Impl::handleHealth(const httplib::Request& req, httplib::Response& res) {
  if (auto r = expectNoParams(req.params); !r) return sendError(res, 400, r.error().message);
  const auto [status, body] = healthJson();
  sendJson(res, status, body);
}

void FrameServer::Impl::routes() {
  // Every other method: 405 on our paths, 404 elsewhere.
  const auto notAllowed = [](const httplib::Request& req, httplib::Response& res) {
    const Route* route = findRoute(req.path);
    if (route == nullptr) return sendError(res, 404, "no such path");
    const bool post = route->method == Method::Post;
    res.set_header("Allow", post ? "POST" : "GET, HEAD");
    sendError(res, 405,
              "method " + req.method + " not allowed on " + req.path +
                  (post ? " (POST only)" : " (GET only)"));
  };
  for (const Route& route : routeTable()) {
    const std::string path(route.path);
    const auto handler = [this, handle = route.handle](const httplib::Request& req,
                                                       httplib::Response& res) {
      handle(*this, req, res);
    };
    if (route.method == Method::Get) {
      http.Get(path, handler);
    } else {
      http.Post(path, handler);
      http.Get(path, notAllowed);
    }
  }
  http.Post(".*", notAllowed);
  http.Put(".*", notAllowed);
  http.Patch(".*", notAllowed);
  http.Delete(".*", notAllowed);
  http.Options(".*", notAllowed);

  // Statuses httplib sets itself (no route, unparsable request, URI too long, ...) get the
  // same JSON body as ours; responses that already have a body are left alone.
  http.set_error_handler(httplib::Server::HandlerWithResponse(
      [noSuchPath = "no such path (" + FrameServer::routeSummary() + ")"](const httplib::Request&,
                                                                          httplib::Response& res) {
        if (!res.body.empty()) return httplib::Server::HandlerResponse::Unhandled;
        std::string message;
        switch (res.status) {
          case 400:
            message = "malformed request (not HTTP/1.x, an unsupported method or bad headers)";
            break;
          case 404:
            message = noSuchPath;
            break;
          case 413:
            message = "request body too large";
            break;
          case 414:
            message = "request URI too long";
            break;
          default:
            message = "request refused";
            break;
        }
        sendError(res, res.status, message);
        return httplib::Server::HandlerResponse::Handled;
      }));
  http.set_exception_handler(
      [](const httplib::Request&, httplib::Response& res, const std::exception_ptr& ep) {
        std::string what = "internal error";
        try {
          if (ep) std::rethrow_exception(ep);
        } catch (const std::exception& e) {
          what = std::string("internal error: ") + e.what();
        } catch (...) {
        }
        sendError(res, 500, what);
      });
  http.set_logger([this](const httplib::Request& req, const httplib::Response& res) {
    {
      const std::lock_guard<std::mutex> lock(countersMutex);
      ++requests;
      ++responsesByStatus[res.status];
      ++requestsByPath[findRoute(req.path) != nullptr ? req.path : std::string("other")];
    }
    served.fetch_add(1, std::memory_order_relaxed);
    if (options.logRequests) {
      std::printf("%s %s %d %zu\n", req.method.c_str(), req.path.c_str(), res.status,
                  res.body.size());
      std::fflush(stdout);
    }
  });
}

FrameServer::FrameServer(std::unique_ptr<Impl> impl) noexcept : impl_(std::move(impl)) {}
FrameServer::~FrameServer() {
  if (impl_ && impl_->generation) impl_->generation->pool->shutdown();
}

Result<std::unique_ptr<FrameServer>> FrameServer::create(const std::string& directory,
                                                         const ServeOptions& options) {
  auto impl = std::make_unique<Impl>();
  impl->options = options;
  impl->directory = directory;
  auto generation = openGeneration(directory, options, 1);
  if (!generation) return std::move(generation).error();
  impl->generation = std::move(*generation);

  // Enough connection threads that every admitted frame request (contexts + queue) can wait
  // for its frame while a few more answer /stats, /healthz and the refusals.
  impl->httpThreads = options.workers + options.queueCapacity + 8;
  const std::size_t threads = impl->httpThreads;
  impl->http.new_task_queue = [threads] {
    // httplib's hook returns a raw pointer; the server owns the queue from then on and deletes
    // it when it stops.
    // NOLINTNEXTLINE(cppcoreguidelines-owning-memory): ownership passes to httplib
    return new BoundedTaskQueue(threads, 4 * threads);
  };
  impl->http.set_keep_alive_timeout(2);
  impl->http.set_keep_alive_max_count(100);
  impl->http.set_read_timeout(5, 0);
  impl->http.set_write_timeout(5, 0);
  impl->http.set_payload_max_length(std::size_t{64} * 1024);
  impl->http.set_tcp_nodelay(true);
  impl->routes();
  return std::unique_ptr<FrameServer>(new FrameServer(std::move(impl)));
}

Result<int> FrameServer::bind() {
  Impl& m = *impl_;
  const int port =
      m.options.port == 0
          ? m.http.bind_to_any_port(m.options.bindAddress)
          : (m.http.bind_to_port(m.options.bindAddress, m.options.port) ? m.options.port : -1);
  if (port <= 0) {
    return makeError(ErrorCode::IoError, "cannot listen on " + m.options.bindAddress + ":" +
                                             std::to_string(m.options.port) +
                                             " (address in use or not local?)");
  }
  m.port = port;
  return port;
}

Result<void> FrameServer::run() {
  Impl& m = *impl_;
  // httplib's stop() only works on a running listener: a watcher calls it once the listener
  // runs and a stop was asked for (stop() itself may come from a signal thread at any time).
  m.running = true;
  std::thread watcher([&m] {
    std::unique_lock<std::mutex> lock(m.stopMutex);
    m.stopWake.wait(lock, [&] { return m.stopRequested.load() || !m.running.load(); });
    while (m.running.load() && !m.http.is_running()) {
      m.stopWake.wait_for(lock, std::chrono::milliseconds(5));
    }
    if (m.running.load()) m.http.stop();
  });
  bool ok = true;
  if (!m.stopRequested) ok = m.http.listen_after_bind();
  {
    const std::lock_guard<std::mutex> lock(m.stopMutex);
    m.running = false;
  }
  m.stopWake.notify_all();
  watcher.join();
  // Every connection has been answered (httplib drains its task queue before returning); the
  // contexts have nothing left to draw.
  m.current()->pool->shutdown();
  if (!ok && !m.stopRequested) {
    return makeError(ErrorCode::IoError,
                     "the HTTP listener failed on port " + std::to_string(m.port));
  }
  return {};
}

void FrameServer::stop() {
  {
    const std::lock_guard<std::mutex> lock(impl_->stopMutex);
    impl_->stopRequested = true;
  }
  impl_->stopWake.notify_all();
}

Result<void> FrameServer::reload() {
  auto number = impl_->reload();
  if (!number) return std::move(number).error();
  return {};
}

std::string FrameServer::deviceName() const { return impl_->current()->pool->deviceName(); }

std::uint64_t FrameServer::requestsServed() const noexcept { return impl_->served.load(); }

}  // namespace pbdam::tools
