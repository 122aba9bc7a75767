// Where the frame loop of `pbdam bench` and `pbdam render` takes each frame's cut from: the
// host's refinement (from the roots, or with the tree kept from frame to frame:
// runtime/CutReuse.h), the host's selection with focus regions (runtime/Selection.h), the device's
// selection passes read back (gpu/GpuSelector.h), no-stall mode's level-capped resident cut
// (streaming/NoStallPolicy.h), or the draw list the device makes (TerrainRenderer::renderSelected),
// which leaves no cut on the host. Thread-safety: none — a source is used by the one thread that
// renders.
#pragma once

#include <memory>
#include <vector>

#include "pbdam/formats/Result.h"
#include "pbdam/runtime/Camera.h"
#include "pbdam/runtime/DatasetView.h"
#include "pbdam/runtime/Refinement.h"
#include "pbdam/runtime/Selection.h"

namespace pbdam::streaming {
class MappedDataset;
}  // namespace pbdam::streaming

namespace pbdam::gpu {

class GpuCache;
class GpuSelector;
class VulkanContext;

/// A frame's cut, one frame after another along a camera path: sources that keep state (a
/// refinement tree, a level cap) assume consecutive frames. Non-copyable.
class CutSource {
 public:
  CutSource() = default;
  CutSource(const CutSource&) = delete;
  CutSource& operator=(const CutSource&) = delete;
  virtual ~CutSource() = default;

  /// The cut to draw for `camera` with `refinement` (tolerance, morph range, level cap). For a
  /// source that draws from the device's list (drawsDeviceList()) an empty cut: the selection
  /// runs inside the frame's submission. Errors: the device's (DeviceError) for device sources.
  virtual formats::Result<runtime::Cut> cut(const runtime::Camera& camera,
                                            const runtime::RefinementOptions& refinement) = 0;

  /// Whether frames are drawn from the list the device makes (TerrainRenderer::renderSelected
  /// with selector()) instead of a host cut through TerrainRenderer::render.
  virtual bool drawsDeviceList() const noexcept { return false; }

  /// The device's selector of the device sources; null for host sources.
  virtual GpuSelector* selector() noexcept { return nullptr; }

  /// The level cap of the last cut (refinement's maxLevel; no-stall mode); −1 for sources
  /// without one.
  virtual int levelCap() const noexcept { return -1; }
  /// The frame drawn from the last cut has been submitted, so its data has been decoded: a
  /// source that held the cut's pages (no-stall under a memory budget) lets them go.
  virtual void cutDecoded() noexcept {}
};

/// The host's refinement: refine() from the roots every frame, or with `reuseTree` the
/// refinement tree kept from frame to frame (IncrementalRefiner: the same cuts, fewer decisions).
/// `view` must outlive the source.
std::unique_ptr<CutSource> hostRefinementCuts(const runtime::DatasetView& view, bool reuseTree);

/// The host's selection with `focus` regions (CutSelector: full detail inside them, the screen
/// error elsewhere, closed upward). `view` must outlive the source.
std::unique_ptr<CutSource> focusCuts(const runtime::DatasetView& view,
                                     std::vector<runtime::FocusRegion> focus);

/// The device's selection passes (with `focus` regions, when any), the cut read back each frame.
/// `context` and `view` must outlive the source. Errors as GpuSelector::create.
formats::Result<std::unique_ptr<CutSource>> deviceSelectionCuts(
    VulkanContext& context, const runtime::DatasetView& view,
    std::vector<runtime::FocusRegion> focus);

/// The draw list the device makes from its own selection (TerrainRenderer::renderSelected): no
/// host cut; drawsDeviceList() is true. `context` and `view` must outlive the source. Errors as
/// GpuSelector::create.
formats::Result<std::unique_ptr<CutSource>> deviceDrawListCuts(VulkanContext& context,
                                                               const runtime::DatasetView& view);

/// No-stall mode: the finest cut whose data is resident, under a level cap that rises by at most
/// one diamond level (two bintree levels) over the previous frame's, so that when a level's data
/// arrives its patches are decoded over a few frames instead of all in one
/// (NoStallPolicy::cutAfter, which takes a finer resident cut at once when none within that rise
/// is). levelCap() is the cap of the last cut. `dataset` must outlive the source. What `cache`
/// (the renderer's GPU cache, when given) holds counts as at hand without its pages.
std::unique_ptr<CutSource> noStallCuts(const streaming::MappedDataset& dataset,
                                       bool holdPages = false,
                                       const std::shared_ptr<const GpuCache>& cache = nullptr);

}  // namespace pbdam::gpu
