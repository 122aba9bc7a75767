// The frame loop of `pbdam fly` (FlyCommand.cpp opens the dataset, the window and the device):
// a FlySession draws each frame offscreen with the Terrain, frames in flight, copies it into the
// acquired swapchain image with the HUD over it, and sums the flight up when it ends. Also what
// the command's two sources share: its options as given and as parsed, and the window's input.
#pragma once

#include <chrono>
#include <cstddef>
#include <cstdint>
#include <deque>
#include <memory>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "FlyControls.h"
#include "FlyHud.h"
#include "FlyScriptDriver.h"
#include "FrameWriter.h"
#include "LightOption.h"
#include "MorphOption.h"
#include "pbdam/formats/CameraPath.h"
#include "pbdam/formats/Result.h"
#include "pbdam/gpu/FrameModes.h"
#include "pbdam/gpu/GpuMemory.h"
#include "pbdam/gpu/Swapchain.h"
#include "pbdam/gpu/Terrain.h"
#include "pbdam/gpu/TerrainRenderer.h"
#include "pbdam/gpu/UniqueHandle.h"
#include "pbdam/gpu/VulkanContext.h"
#include "pbdam/runtime/Camera.h"
#include "pbdam/runtime/DatasetView.h"
#include "pbdam/streaming/MappedDataset.h"

struct GLFWwindow;

namespace pbdam::tools::fly_internal {

/// The command line as given.
struct FlyCliOptions {
  std::string dir;
  std::uint32_t width = 1280;
  std::uint32_t height = 720;
  bool fullscreen = false;
  std::string device;
  double tolerancePixels = 3.0;
  double fovDegrees = 60.0;
  MorphCliOptions morph;
  double exaggeration = 1.0;
  LightCliOptions light;
  std::string camera;
  std::string goTo;
  double gpuCacheMiB = 256.0;
  std::string present = "fifo";
  std::string mode = "no-stall";
  std::string prefetch = "on";
  double lookahead = 0.5;
  std::uint32_t framesInFlight = 2;
  std::string record;
  std::string replay;
  std::string script;
  double exitAfterSeconds = 0.0;
  std::string screenshots = "pbdam_fly";
  std::string stats;
  bool validation = false;
  double memoryBudgetMiB = 0.0;
};

/// The options parsed once.
struct FlyModes final {
  gpu::StreamingMode mode = gpu::StreamingMode::NoStall;
  bool prefetch = true;
  bool morph = true;
  gpu::PresentMode present = gpu::PresentMode::Fifo;
  Light light;  ///< --time, --sun, --time-scale, --ambient; [ and ] move the time by an hour
};

/// Prints "pbdam: MESSAGE" on stderr and returns kExitBadInput.
int badInput(const std::string& message);

/// Input from the window, turned into control calls (GLFW's callbacks reach it through the
/// window's user pointer).
struct WindowInput final {
  FlyControls* controls = nullptr;
  bool dragging = false;
  double lastX = 0.0;
  double lastY = 0.0;
};

/// Sends the window's keys, typed characters, left-button drags and wheel to `input.controls`;
/// `input` must outlive the window's event polling.
void installCallbacks(GLFWwindow* window, WindowInput& input);

/// A frame submitted and not yet collected.
struct InFlight final {
  std::size_t frame = 0;
  double traversalMs = 0.0;
  std::uint64_t faults = 0;
  std::optional<std::string> screenshot;  ///< the PNG to write from its pixels
};

/// The per-frame figures kept for the HUD and the summary.
struct FlyFigures final {
  std::vector<double> frameMs;
  std::vector<double> frameStartS;
  std::vector<double> drawMs;
  std::uint64_t faults = 0;
  std::uint64_t faultsAfterFirst = 0;
  std::size_t dataStalls = 0;
  std::size_t screenshots = 0;
  gpu::FrameStats last;
  double lastTraversalMs = 0.0;
};

/// Host-visible buffers for the HUD panel, one per acquire slot.
struct HudBuffers final {
  std::vector<gpu::GpuBuffer> buffers;
  std::vector<std::uint64_t> sizes;
};

/// One flight in an open window: the swapchain, the terrain and the frames in flight, drawn until
/// the window closes, the script or replay ends, or --exit-after-s passes.
class FlySession final {
 public:
  using Clock = std::chrono::steady_clock;

  FlySession(const FlyCliOptions& c, const FlyModes& modes,
             std::shared_ptr<streaming::MappedDataset> dataset, gpu::VulkanContext& context,
             GLFWwindow* window)
      : c_(c),
        modes_(modes),
        dataset_(std::move(dataset)),
        view_(dataset_->view()),
        context_(context),
        window_(window) {}

  /// Flies until the window closes, the script or replay ends, or --exit-after-s passes; prints
  /// the flight's figures (and writes --record, --stats); returns the exit status.
  int run(FlyControls& controls, FlyScriptDriver& driver);

 private:
  formats::Result<void> setUp();
  formats::Result<void> drain();
  formats::Result<void> collectOne();
  formats::Result<void> resizeTo(std::uint32_t width, std::uint32_t height);
  std::vector<std::string> hudLines(const FlyControls& controls, double fps) const;
  /// The light of the frame at `t` as `pbdam render` options, for a screenshot's side file.
  std::string lightOptionsText(const FlyControls& controls, double t) const;
  formats::Result<void> frame(FlyControls& controls, double t);
  int finish(int status);

  const FlyCliOptions& c_;
  const FlyModes& modes_;
  std::shared_ptr<streaming::MappedDataset> dataset_;  ///< the terrain's, and the HUD's view
  const runtime::DatasetView& view_;
  gpu::VulkanContext& context_;
  GLFWwindow* window_;

  gpu::Swapchain swapchain_;
  std::unique_ptr<gpu::Terrain> terrain_;
  std::vector<gpu::UniqueSemaphore> acquired_;
  HudBuffers hud_;
  HudPixels hudPixels_;
  Clock::time_point hudDrawn_{};
  std::deque<InFlight> inFlight_;
  FrameWriter writer_{2};
  FlyFigures figures_;
  std::vector<formats::CameraPathPoint> recorded_;
  std::size_t frames_ = 0;
  std::size_t shotsTaken_ = 0;
  bool viewshedOn_ = false;
  // The first frame's camera: a placed sun stands over it.
  std::optional<runtime::Camera> lightTarget_;
  std::string sunLine_;  // the light, for the HUD
  gpu::FrameSettings settings_;
  bool recreate_ = false;
};

}  // namespace pbdam::tools::fly_internal
