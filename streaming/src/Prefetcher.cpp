// Camera prediction and madvise prefetch (Prefetcher.h).
#include "pbdam/streaming/Prefetcher.h"

#include <algorithm>
#include <cmath>
#include <glm/geometric.hpp>
#include <glm/trigonometric.hpp>

using namespace pbdam::formats;
using namespace pbdam::runtime;

namespace pbdam::streaming {

void CameraPredictor::observe(double timeSeconds, const Camera& camera) {
  if (!samples_.empty() && timeSeconds <= samples_.back().time) samples_.clear();
  samples_.push_back({timeSeconds, camera});
  while (samples_.size() > 2) samples_.pop_front();
}

std::optional<double> CameraPredictor::lastTime() const {
  if (samples_.empty()) return std::nullopt;
  return samples_.back().time;
}

std::optional<Camera> CameraPredictor::predict(double timeSeconds) const {
  if (samples_.empty()) return std::nullopt;
  const Sample& last = samples_.back();
  if (samples_.size() < 2) return last.camera;
  const Sample& prev = samples_.front();
  const double s = (timeSeconds - last.time) / (last.time - prev.time);
  const auto extrapolate = [s](const glm::dvec3& a, const glm::dvec3& b) {
    return b + s * (b - a);
  };
  const glm::dvec3 position = extrapolate(prev.camera.position(), last.camera.position());
  glm::dvec3 forward = extrapolate(prev.camera.forward(), last.camera.forward());
  glm::dvec3 up = extrapolate(prev.camera.up(), last.camera.up());
  if (glm::length(forward) < 1e-9 || glm::length(glm::cross(forward, up)) < 1e-9) {
    forward = last.camera.forward();
    up = last.camera.up();
  }
  forward = glm::normalize(forward);
  const glm::dvec3 right = glm::normalize(glm::cross(forward, up));
  up = glm::cross(right, forward);
  Camera predicted(position, right, up, forward, last.camera.viewport());
  predicted.setNearMeters(last.camera.nearMeters());
  return predicted;
}

Prefetcher::Prefetcher(const MappedDataset& dataset, const PrefetchOptions& options)
    : dataset_(dataset), options_(options), worker_([this] { run(); }) {}

Prefetcher::~Prefetcher() { stop(); }

void Prefetcher::stop() {
  {
    std::lock_guard lock(mutex_);
    stopping_ = true;
  }
  wake_.notify_all();
  if (worker_.joinable()) worker_.join();
}

void Prefetcher::observe(double timeSeconds, const Camera& camera) {
  {
    std::lock_guard lock(mutex_);
    pending_.emplace_back(timeSeconds, camera);
    while (pending_.size() > 8) pending_.pop_front();
  }
  wake_.notify_one();
}

PrefetchStats Prefetcher::stats() const {
  return {predictions_.load(), rangesAdvised_.load(), bytesAdvised_.load(), rangesResident_.load(),
          rangesDeferred_.load()};
}

void Prefetcher::run() {
  for (;;) {
    std::deque<std::pair<double, Camera>> batch;
    {
      std::unique_lock lock(mutex_);
      wake_.wait(lock, [this] { return stopping_ || !pending_.empty(); });
      if (stopping_) return;
      batch.swap(pending_);
    }
    for (const auto& [t, camera] : batch) predictor_.observe(t, camera);
    const double last = *predictor_.lastTime();
    if (!predictor_.predict(last)) continue;
    ++cycle_;
    cycleBytes_ = 0;
    // A quarter, a half and the whole look-ahead, nearest first: what the next frames need is
    // asked for before what the look-ahead needs, and a turn the extrapolation misses at the
    // far horizon is still caught near. A range asked for at one horizon is not asked again.
    // The nearest horizon asks for exactly what the next frames need, first; the farther ones
    // over a wider view at a finer tolerance (PrefetchOptions).
    RefinementOptions finer = options_.refinement;
    finer.tolerancePixels *= options_.toleranceScale;
    for (const double share : {0.125, 0.25, 0.5, 1.0}) {
      const auto predicted = predictor_.predict(last + share * options_.lookaheadSeconds);
      if (share == 0.125) {
        prefetch(refine(dataset_.view(), *predicted, options_.refinement));
      } else {
        prefetch(refine(dataset_.view(), widened(*predicted), finer));
      }
    }
    predictions_.fetch_add(1, std::memory_order_relaxed);
  }
}

Camera Prefetcher::widened(const Camera& camera) const {
  if (!(options_.fovMarginDegrees > 0.0)) return camera;
  // The same pixels per radian (so the same levels of detail) over a wider view: the image
  // grows with the tangent of the half angle.
  Viewport viewport = camera.viewport();
  const double before = std::tan(glm::radians(viewport.fovYDegrees) / 2.0);
  viewport.fovYDegrees = std::min(viewport.fovYDegrees + options_.fovMarginDegrees, 170.0);
  const double grow = std::tan(glm::radians(viewport.fovYDegrees) / 2.0) / before;
  viewport.width = static_cast<std::uint32_t>(std::ceil(viewport.width * grow));
  viewport.height = static_cast<std::uint32_t>(std::ceil(viewport.height * grow));
  Camera wide(camera.position(), camera.right(), camera.up(), camera.forward(), viewport);
  wide.setNearMeters(camera.nearMeters());
  return wide;
}

void Prefetcher::prefetch(const Cut& cut) {
  const DatasetView& view = dataset_.view();
  for (const CutPatch& p : cut.patches) {
    const NodeRecord n = view.node(p.node);
    adviseRange(p.node.face, n.blobOffset, n.blobsBytes(), ResidentKey::patch(p.node));
  }
  for (const TileKey& t : cut.tiles) {
    const TextureRecord r = view.textureNode(t);
    adviseRange(t.face, r.blobOffset, r.blobsBytes(), ResidentKey::tile(t));
  }
  // Forget ranges advised long ago: the kernel may have dropped them since.
  if (cycle_ % 64 == 0) {
    std::erase_if(advisedAt_, [this](const auto& kv) { return kv.second + 64 < cycle_; });
  }
}

void Prefetcher::adviseRange(int face, std::uint64_t offset, std::uint64_t bytes, ResidentKey key) {
  if (bytes == 0) return;
  auto [it, fresh] = advisedAt_.try_emplace(key.packed, cycle_);
  const MappedFile& file = dataset_.faceFile(face);
  const auto resident = file.residentPages(offset, bytes);
  const bool wasResident = resident && resident->first == resident->second;
  // Advised recently: not again, unless an earlier prediction advised it and its pages left
  // the page cache since. A proactive reclaimer (DAMON's pageout, senpai) takes pages that were
  // read ahead and not yet mapped first, as cold, with plenty of memory free.
  if (!fresh && it->second + 16 > cycle_ && (it->second == cycle_ || wasResident)) return;
  it->second = cycle_;
  if (!wasResident && options_.pageRoomBytes > 0 &&
      cycleBytes_ + bytes > options_.pageRoomBytes / 2) {
    // Over this prediction's share of the page room: asked for again by the next one.
    advisedAt_.erase(it);
    rangesDeferred_.fetch_add(1, std::memory_order_relaxed);
    return;
  }
  if (wasResident) {
    rangesResident_.fetch_add(1, std::memory_order_relaxed);
  } else if (file.willNeed(offset, bytes)) {
    cycleBytes_ += bytes;
    rangesAdvised_.fetch_add(1, std::memory_order_relaxed);
    bytesAdvised_.fetch_add(bytes, std::memory_order_relaxed);
  }
  if (options_.onRange) options_.onRange({key, face, offset, bytes, wasResident, cycle_});
}

}  // namespace pbdam::streaming
