// The frame loop's cut sources (CutSource.h).
#include "pbdam/gpu/CutSource.h"

#include <utility>

#include "pbdam/gpu/GpuCache.h"
#include "pbdam/gpu/GpuSelector.h"
#include "pbdam/runtime/CutReuse.h"
#include "pbdam/streaming/NoStallPolicy.h"

using namespace pbdam::formats;
using namespace pbdam::runtime;

namespace pbdam::gpu {
namespace {

class FreshRefinementCuts final : public CutSource {
 public:
  explicit FreshRefinementCuts(const DatasetView& view) : view_(view) {}
  Result<Cut> cut(const Camera& camera, const RefinementOptions& refinement) override {
    return refine(view_, camera, refinement);
  }

 private:
  const DatasetView& view_;
};

class ReusedRefinementCuts final : public CutSource {
 public:
  explicit ReusedRefinementCuts(const DatasetView& view) : incremental_(view) {}
  Result<Cut> cut(const Camera& camera, const RefinementOptions& refinement) override {
    return incremental_.update(camera, refinement);
  }

 private:
  IncrementalRefiner incremental_;
};

class FocusCuts final : public CutSource {
 public:
  FocusCuts(const DatasetView& view, std::vector<FocusRegion> focus)
      : selector_(view), focus_(std::move(focus)) {}
  Result<Cut> cut(const Camera& camera, const RefinementOptions& refinement) override {
    SelectionOptions options;
    options.refinement = refinement;
    options.focus = focus_;
    return selector_.select(camera, options);
  }

 private:
  CutSelector selector_;
  std::vector<FocusRegion> focus_;
};

class DeviceSelectionCuts final : public CutSource {
 public:
  DeviceSelectionCuts(GpuSelector selector, std::vector<FocusRegion> focus)
      : selector_(std::move(selector)), focus_(std::move(focus)) {}
  Result<Cut> cut(const Camera& camera, const RefinementOptions& refinement) override {
    SelectionOptions options;
    options.refinement = refinement;
    options.focus = focus_;
    return selector_.select(camera, options);
  }
  GpuSelector* selector() noexcept override { return &selector_; }

 private:
  GpuSelector selector_;
  std::vector<FocusRegion> focus_;
};

class DeviceDrawListCuts final : public CutSource {
 public:
  explicit DeviceDrawListCuts(GpuSelector selector) : selector_(std::move(selector)) {}
  Result<Cut> cut(const Camera& /*camera*/, const RefinementOptions& /*refinement*/) override {
    return Cut{};
  }
  bool drawsDeviceList() const noexcept override { return true; }
  GpuSelector* selector() noexcept override { return &selector_; }

 private:
  GpuSelector selector_;
};

/// The GPU cache's residency as the no-stall policy asks for it (none without a cache).
streaming::NoStallCached cachedIn(const std::shared_ptr<const GpuCache>& cache) {
  if (!cache) return {};
  return {[cache](const runtime::NodeKey& node) { return cache->holds(node); },
          [cache](const runtime::TileKey& tile) { return cache->holds(tile); }};
}

class NoStallCuts final : public CutSource {
 public:
  NoStallCuts(const streaming::MappedDataset& dataset, bool holdPages,
              const std::shared_ptr<const GpuCache>& cache)
      : policy_(dataset, holdPages, cachedIn(cache)) {}
  Result<Cut> cut(const Camera& camera, const RefinementOptions& refinement) override {
    streaming::NoStallCut capped = policy_.cutAfter(camera, refinement, cap_);
    cap_ = capped.levelCap;
    held_ = std::move(capped.held);  // until cutDecoded()
    return std::move(capped.cut);
  }
  int levelCap() const noexcept override { return cap_; }
  void cutDecoded() noexcept override { held_ = streaming::HeldPages(); }

 private:
  streaming::NoStallPolicy policy_;
  int cap_ = -1;               ///< the previous frame's level cap (−1 before the first)
  streaming::HeldPages held_;  ///< the last cut's pages (with holdPages)
};

}  // namespace

std::unique_ptr<CutSource> hostRefinementCuts(const DatasetView& view, bool reuseTree) {
  if (reuseTree) return std::make_unique<ReusedRefinementCuts>(view);
  return std::make_unique<FreshRefinementCuts>(view);
}

std::unique_ptr<CutSource> focusCuts(const DatasetView& view, std::vector<FocusRegion> focus) {
  return std::make_unique<FocusCuts>(view, std::move(focus));
}

Result<std::unique_ptr<CutSource>> deviceSelectionCuts(VulkanContext& context,
                                                       const DatasetView& view,
                                                       std::vector<FocusRegion> focus) {
  auto selector = GpuSelector::create(context, view);
  if (!selector) return std::move(selector).error();
  return std::unique_ptr<CutSource>(
      std::make_unique<DeviceSelectionCuts>(std::move(*selector), std::move(focus)));
}

Result<std::unique_ptr<CutSource>> deviceDrawListCuts(VulkanContext& context,
                                                      const DatasetView& view) {
  auto selector = GpuSelector::create(context, view);
  if (!selector) return std::move(selector).error();
  return std::unique_ptr<CutSource>(std::make_unique<DeviceDrawListCuts>(std::move(*selector)));
}

std::unique_ptr<CutSource> noStallCuts(const streaming::MappedDataset& dataset, bool holdPages,
                                       const std::shared_ptr<const GpuCache>& cache) {
  return std::make_unique<NoStallCuts>(dataset, holdPages, cache);
}

}  // namespace pbdam::gpu
