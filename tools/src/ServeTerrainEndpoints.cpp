// The terrain endpoints of `pbdam serve` (ServeServer.h): GET /frame, /height, /los and
// /viewshed. Each checks its request against the server's settings, draws or queries on the
// served generation, and answers with the encoded image or JSON, or a 4xx/5xx JSON error (503 +
// Retry-After when the contexts or the device are busy).
#include <httplib.h>

#include <algorithm>
#include <cctype>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <memory>
#include <sstream>
#include <string>
#include <string_view>
#include <utility>

#include "FrameImage.h"
#include "HeightJson.h"
#include "ServeQueries.h"
#include "ServeRequest.h"
#include "ServeServerImpl.h"
#include "ViewshedOutput.h"
#include "pbdam/runtime/SurfaceQuery.h"
#include "pbdam/streaming/MappedDataset.h"

using namespace pbdam::formats;
using namespace pbdam::runtime;

namespace pbdam::tools {

using namespace serve_internal;

namespace {

/// A terrain query's error in the server's words: the command line's option names
/// (runtime::viewshedGrid, gpu::sightlineOverTerrain) become the query's parameters.
std::string queryMessage(std::string message) {
  for (const auto& [option, parameter] :
       {std::pair{"--at", "parameter 'at'"}, std::pair{"--radius-m", "parameter 'radius_m'"},
        std::pair{"--cell-m", "parameter 'cell_m'"}, std::pair{"--from", "parameter 'from'"},
        std::pair{"--to", "parameter 'to'"}}) {
    for (std::size_t at = message.find(option); at != std::string::npos;
         at = message.find(option, at + 1)) {
      const std::size_t end = at + std::string_view(option).size();
      if (end < message.size() &&
          (std::isalnum(static_cast<unsigned char>(message[end])) != 0 || message[end] == '-')) {
        continue;  // a longer option
      }
      message.replace(at, end - at, parameter);
    }
  }
  return message;
}

/// 503 for a terrain query that found the device busy for the whole wait.
void sendBusy(httplib::Response& res) {
  res.set_header("Retry-After", "1");
  sendError(res, 503, "busy: another terrain query held the device for the whole wait");
}

}  // namespace

int FrameServer::Impl::retryAfterSeconds(const RenderPool& pool) {
  // About the time the contexts need to work off a full queue, at least a second.
  const RenderPoolStats s = pool.stats();
  const double meanMs = s.frames > 0 ? s.renderMsTotal / static_cast<double>(s.frames) : 100.0;
  const double backlogMs =
      meanMs * static_cast<double>(s.queued + s.rendering) / static_cast<double>(s.workers);
  return std::max(1, static_cast<int>(std::ceil(backlogMs / 1000.0)));
}

void FrameServer::Impl::handleFrame(const httplib::Request& req, httplib::Response& res) const {
  const auto received = Clock::now();
  // The whole request draws from one generation, even when a reload swaps it meanwhile.
  const std::shared_ptr<Generation> g = current();
  Result<FrameQuery> query = parseFrameQuery(req.params, g->dataset->view().planet());
  if (!query) return sendError(res, 400, query.error().message);
  query->request.morphRange = query->morph.value_or(options.morph) ? options.morphRange : 0.0;
  if (query->exaggeration && *query->exaggeration != options.exaggeration) {
    std::ostringstream what;
    what << "parameter 'exaggeration': " << *query->exaggeration
         << " is not this server's exaggeration " << options.exaggeration
         << " (pbdam serve --exaggeration)";
    return sendError(res, 400, what.str());
  }
  query->request.exaggeration = options.exaggeration;
  if (!options.atmosphere) {
    if (query->request.light.air == Light::Air::On) {
      return sendError(res, 400,
                       "parameter 'atmosphere': this server runs without the atmosphere "
                       "(pbdam serve --atmosphere off)");
    }
    query->request.light.air = Light::Air::Off;
  }
  if (query->viewshed) {
    auto drape = g->queries->viewshed(*query->viewshed);
    if (drape.busy) return sendBusy(res);
    if (!*drape.result) {
      return sendError(res, statusFor(drape.result->error()),
                       "parameter 'viewshed': " + queryMessage(drape.result->error().message));
    }
    query->request.overlay = (**drape.result)->overlay;
  }
  const auto deadline = received + std::chrono::duration_cast<Clock::duration>(
                                       std::chrono::duration<double>(options.deadlineSeconds));
  FrameOutcome outcome = g->pool->render(query->request, deadline);
  switch (outcome.refusal) {
    case FrameRefusal::QueueFull:
      res.set_header("Retry-After", std::to_string(retryAfterSeconds(*g->pool)));
      return sendError(res, 503,
                       "overloaded: every render context is busy and the queue of " +
                           std::to_string(options.queueCapacity) + " requests is full");
    case FrameRefusal::Deadline:
      res.set_header("Retry-After", std::to_string(retryAfterSeconds(*g->pool)));
      return sendError(res, 503,
                       "deadline: the frame was not drawn within " +
                           std::to_string(options.deadlineSeconds) + " s");
    case FrameRefusal::ShuttingDown:
      return sendError(res, 503, "the server is shutting down");
    case FrameRefusal::None:
      break;
  }
  Result<FrameResult>& frame = *outcome.frame;
  if (!frame) return sendError(res, statusFor(frame.error()), frame.error().message);
  const auto encodeStart = Clock::now();
  auto bytes = encodeFrameImage(frame->image, query->encoding, query->jpegQuality);
  if (!bytes) return sendError(res, 500, bytes.error().message);
  const double encodeMs =
      std::chrono::duration<double, std::milli>(Clock::now() - encodeStart).count();
  const gpu::FrameStats& s = frame->stats;
  char number[32];
  const auto header = [&](const char* name, double v) {
    std::snprintf(number, sizeof number, "%.3f", v);
    res.set_header(name, number);
  };
  res.set_header("X-Pbdam-Patches", std::to_string(s.patches));
  res.set_header("X-Pbdam-Triangles", std::to_string(s.triangles));
  res.set_header("X-Pbdam-Tiles", std::to_string(s.tiles));
  res.set_header("X-Pbdam-Context", std::to_string(frame->worker));
  res.set_header("X-Pbdam-Cache-Hits", std::to_string(s.hits));
  res.set_header("X-Pbdam-Cache-Misses", std::to_string(s.misses));
  res.set_header("X-Pbdam-Passes", std::to_string(s.passes));
  header("X-Pbdam-Queue-Ms", frame->queueMs);
  header("X-Pbdam-Traversal-Ms", frame->traversalMs);
  header("X-Pbdam-Frame-Ms", s.frameMs);
  header("X-Pbdam-Encode-Ms", encodeMs);
  res.set_header("Cache-Control", "no-store");
  res.status = 200;
  res.body.assign(reinterpret_cast<const char*>(bytes->data()), bytes->size());
  res.set_header("Content-Type",
                 query->encoding == FrameEncoding::Png ? "image/png" : "image/jpeg");
}

void FrameServer::Impl::handleHeight(const httplib::Request& req, httplib::Response& res) const {
  Result<HeightQuery> query = parseHeightQuery(req.params);
  if (!query) return sendError(res, 400, query.error().message);
  const std::shared_ptr<Generation> g = current();
  const DatasetView& view = g->dataset->view();
  auto h = surfaceHeightAt(view, query->latDegrees, query->lonDegrees);
  if (!h) return sendError(res, statusFor(h.error()), h.error().message);
  sendJson(res, 200,
           surfaceHeightJson(query->latDegrees, query->lonDegrees, *h, view.manifest(),
                             g->dataset->voidAt(query->latDegrees, query->lonDegrees)));
}

void FrameServer::Impl::handleLos(const httplib::Request& req, httplib::Response& res) const {
  Result<LosQuery> query = parseLosQuery(req.params);
  if (!query) return sendError(res, 400, query.error().message);
  const std::shared_ptr<Generation> g = current();
  auto outcome = g->queries->sightline(query->from, query->to);
  if (outcome.busy) return sendBusy(res);
  const Result<gpu::TerrainSightline>& line = *outcome.result;
  if (!line) return sendError(res, statusFor(line.error()), queryMessage(line.error().message));
  sendJson(res, 200, sightlineJson(g->dataset->view().planet(), *line));
}

void FrameServer::Impl::handleViewshed(const httplib::Request& req, httplib::Response& res) const {
  Result<ViewshedQuery> query = parseViewshedQuery(req.params);
  if (!query) return sendError(res, 400, query.error().message);
  const std::shared_ptr<Generation> g = current();
  auto outcome = g->queries->viewshed(query->request);
  if (outcome.busy) return sendBusy(res);
  if (!*outcome.result) {
    return sendError(res, statusFor(outcome.result->error()),
                     queryMessage(outcome.result->error().message));
  }
  const ServedViewshed& answer = ***outcome.result;
  res.set_header("Cache-Control", "no-store");
  switch (query->format) {
    case ViewshedFormat::Json:
      return sendJson(res, 200, viewshedJson(answer.viewshed, answer.heightAboveGroundMeters));
    case ViewshedFormat::GeoTiff: {
      auto tiff = viewshedGeoTiff(answer.viewshed);
      if (!tiff) return sendError(res, 500, tiff.error().message);
      res.status = 200;
      res.body.assign(reinterpret_cast<const char*>(tiff->data()), tiff->size());
      res.set_header("Content-Type", "image/tiff");
      res.set_header("Content-Disposition", "attachment; filename=\"viewshed.tif\"");
      return;
    }
    case ViewshedFormat::Png: {
      auto png = encodeRgbaPng(answer.overlay->image);
      if (!png) return sendError(res, 500, png.error().message);
      res.status = 200;
      res.body.assign(reinterpret_cast<const char*>(png->data()), png->size());
      res.set_header("Content-Type", "image/png");
      return;
    }
  }
}

}  // namespace pbdam::tools
