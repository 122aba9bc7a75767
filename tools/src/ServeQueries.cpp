// Line of sight and viewsheds for `pbdam serve` (ServeQueries.h).
#include "ServeQueries.h"

#include <cstdio>

#include "ViewshedOutput.h"

using namespace pbdam::formats;
using namespace pbdam::runtime;

namespace pbdam::tools {
namespace {

/// The request as the key of the kept viewsheds: every number exactly, defaults as "-".
std::string keyOf(const ViewshedRequest& r) {
  char text[160];
  const auto optional = [](const std::optional<double>& v) { return v ? *v : -1.0; };
  std::snprintf(text, sizeof text, "%.17g,%.17g,%.17g,%.17g,%.17g", r.latDegrees, r.lonDegrees,
                r.heightAboveGroundMeters, optional(r.radiusMeters), optional(r.cellMeters));
  return text;
}

}  // namespace

bool ServeQueries::takeDevice() {
  {
    std::unique_lock<std::mutex> lock(deviceMutex_);
    if (deviceFree_.wait_for(lock, wait_, [this] { return !deviceBusy_; })) {
      deviceBusy_ = true;
      return true;
    }
  }
  const std::lock_guard<std::mutex> counters(mutex_);
  ++stats_.busy;
  return false;
}

void ServeQueries::releaseDevice() noexcept {
  {
    const std::lock_guard<std::mutex> lock(deviceMutex_);
    deviceBusy_ = false;
  }
  deviceFree_.notify_one();
}

QueryOutcome<std::shared_ptr<const ServedViewshed>> ServeQueries::viewshed(
    const ViewshedRequest& request) {
  QueryOutcome<std::shared_ptr<const ServedViewshed>> outcome;
  const std::string key = keyOf(request);
  {
    const std::lock_guard<std::mutex> lock(mutex_);
    for (auto it = kept_.begin(); it != kept_.end(); ++it) {
      if (it->first != key) continue;
      kept_.splice(kept_.begin(), kept_, it);
      ++stats_.viewshedHits;
      outcome.result = kept_.front().second;
      return outcome;
    }
  }
  auto grid = viewshedGrid(view_, request);
  if (!grid) {
    outcome.result = std::move(grid).error();
    return outcome;
  }
  if (grid->cells > kServeMaxViewshedCells) {
    outcome.result =
        makeError(ErrorCode::InvalidArgument,
                  "the viewshed would have " + std::to_string(grid->cells) +
                      " cells a side; the server "
                      "computes at most " +
                      std::to_string(kServeMaxViewshedCells) + " (raise cell_m or lower radius_m)");
    return outcome;
  }
  if (!takeDevice()) {
    outcome.busy = true;
    return outcome;
  }
  auto computed = [&] {
    const DeviceTurn turn(*this);
    return gpu::viewshedOverTerrain(context_, view_, *grid);
  }();
  if (!computed) {
    outcome.result = std::move(computed).error();
    return outcome;
  }
  auto served = std::make_shared<ServedViewshed>();
  served->overlay = viewshedOverlay(*computed);
  served->viewshed = std::move(*computed);
  served->heightAboveGroundMeters = request.heightAboveGroundMeters;
  {
    const std::lock_guard<std::mutex> lock(mutex_);
    ++stats_.viewsheds;
    kept_.emplace_front(key, served);
    if (kept_.size() > kKept) kept_.pop_back();
  }
  outcome.result = std::shared_ptr<const ServedViewshed>(std::move(served));
  return outcome;
}

QueryOutcome<gpu::TerrainSightline> ServeQueries::sightline(const gpu::GroundPoint& from,
                                                            const gpu::GroundPoint& to) {
  QueryOutcome<gpu::TerrainSightline> outcome;
  if (!takeDevice()) {
    outcome.busy = true;
    return outcome;
  }
  {
    const DeviceTurn turn(*this);
    outcome.result = gpu::sightlineOverTerrain(context_, view_, from, to);
  }
  const std::lock_guard<std::mutex> lock(mutex_);
  ++stats_.sightlines;
  return outcome;
}

ServeQueryStats ServeQueries::stats() const {
  const std::lock_guard<std::mutex> lock(mutex_);
  return stats_;
}

}  // namespace pbdam::tools
