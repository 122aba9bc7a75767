// `pbdam fly`: an interactive flythrough in a window (GLFW on X11, Vulkan WSI). Each frame is
// drawn offscreen by the TerrainRenderer with frames in flight, exactly as `pbdam render` draws
// it, and copied into the acquired swapchain image by the frame's own submission, with the
// heads-up display over it (FlyHud.h). The controls (FlyControls.h) move the camera; no-stall
// mode with prefetch from the live camera keeps the render thread off the disk. The flight can
// be recorded as a camera path (`pbdam bench`, `pbdam render --path`), replayed, and driven by a
// script of timed events (tests): FlyScriptDriver.h.
#define GLFW_INCLUDE_VULKAN
#include <GLFW/glfw3.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <deque>
#include <filesystem>
#include <fstream>
#include <functional>
#include <iostream>
#include <memory>
#include <numeric>
#include <optional>
#include <sstream>
#include <string>
#include <vector>

#include "BenchReport.h"
#include "Commands.h"
#include "ExaggerationOption.h"
#include "FlyControls.h"
#include "FlyHud.h"
#include "FlyScriptDriver.h"
#include "FrameImage.h"
#include "FrameWriter.h"
#include "LightOption.h"
#include "MorphOption.h"
#include "ViewshedOutput.h"
#include "pbdam/formats/CameraPath.h"
#include "pbdam/formats/NumberList.h"
#include "pbdam/gpu/FrameModes.h"
#include "pbdam/gpu/GpuMemory.h"
#include "pbdam/gpu/GpuViewshed.h"
#include "pbdam/gpu/Swapchain.h"
#include "pbdam/gpu/Terrain.h"
#include "pbdam/gpu/TerrainRenderer.h"
#include "pbdam/gpu/VulkanContext.h"
#include "pbdam/runtime/Camera.h"
#include "pbdam/runtime/Sun.h"
#include "pbdam/runtime/SurfaceQuery.h"
#include "pbdam/streaming/MappedDataset.h"
#include "pbdam/streaming/MemoryBudget.h"
#include "pbdam/streaming/NoStallPolicy.h"
#include "pbdam/streaming/Prefetcher.h"
#include "pbdam/streaming/ProcessMemory.h"

using namespace pbdam::formats;
using namespace pbdam::runtime;
using namespace pbdam::streaming;
using namespace pbdam::gpu;

namespace pbdam::tools {
namespace {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

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
  StreamingMode mode = StreamingMode::NoStall;
  bool prefetch = true;
  bool morph = true;
  gpu::PresentMode present = gpu::PresentMode::Fifo;
  Light light;  ///< --time, --sun, --time-scale, --ambient; [ and ] move the time by an hour
};

int badInput(const std::string& message) {
  std::cerr << "pbdam: " << message << "\n";
  return kExitBadInput;
}

double secondsBetween(Clock::time_point a, Clock::time_point b) {
  return std::chrono::duration<double>(b - a).count();
}

int checkFlyOptions(const FlyCliOptions& c, FlyModes& modes) {
  if (c.width < 16 || c.height < 16 || c.width > 16384 || c.height > 16384) {
    return badInput("--width and --height must be in 16..16384 pixels");
  }
  if (!std::isfinite(c.tolerancePixels) || c.tolerancePixels <= 0.0) {
    return badInput("--tolerance-px must be a positive number of pixels");
  }
  if (auto r = checkExaggeration(c.exaggeration); !r) return reportError(r.error());
  if (!std::isfinite(c.fovDegrees) || c.fovDegrees <= 1.0 || c.fovDegrees >= 179.0) {
    return badInput("--fov-deg must be in (1, 179) degrees");
  }
  if (!std::isfinite(c.gpuCacheMiB) || c.gpuCacheMiB <= 0.0 || c.gpuCacheMiB > 1048576.0) {
    return badInput("--gpu-cache-mib must be a positive number of MiB");
  }
  if (c.framesInFlight < 1 || c.framesInFlight > gpu::TerrainRenderer::kMaxFramesInFlight) {
    return badInput("--frames-in-flight must be in 1.." +
                    std::to_string(gpu::TerrainRenderer::kMaxFramesInFlight));
  }
  if (!std::isfinite(c.lookahead) || c.lookahead < 0.0 || c.lookahead > 10.0) {
    return badInput("--lookahead-s must be in 0..10 seconds");
  }
  if (!std::isfinite(c.memoryBudgetMiB) || c.memoryBudgetMiB < 0.0 ||
      c.memoryBudgetMiB > 16777216.0) {
    return badInput("--memory-budget-mib must be a number of MiB >= 0 (0: the cgroup's limit)");
  }
  if (!std::isfinite(c.exitAfterSeconds) || c.exitAfterSeconds < 0.0) {
    return badInput("--exit-after-s must be a number of seconds >= 0");
  }
  const std::optional<gpu::PresentMode> present = gpu::parsePresentMode(c.present);
  if (!present) {
    return badInput("--present '" + c.present + "': expected fifo, mailbox or immediate");
  }
  modes.present = *present;
  auto light = parseLight(c.light);
  if (!light) return badInput(light.error().message);
  modes.light = *light;
  auto mode = parseStreamingMode(c.mode);
  if (!mode) return badInput(mode.error().message);
  modes.mode = *mode;
  if (c.prefetch != "on" && c.prefetch != "off") {
    return badInput("--prefetch '" + c.prefetch + "': expected on or off");
  }
  modes.prefetch = c.prefetch == "on";
  if (!c.camera.empty() && !c.replay.empty()) {
    return badInput("give at most one of --camera and --replay");
  }
  if (!c.record.empty()) {
    if (auto r = checkOutputDirectory(c.record); !r) return reportError(r.error());
  }
  if (auto r = checkOutputDirectory(c.screenshots); !r) return reportError(r.error());
  if (!c.stats.empty()) {
    if (auto r = checkOutputDirectory(c.stats); !r) return reportError(r.error());
  }
  return kExitOk;
}

std::string poseText(const CameraPose& p) {
  char text[256];
  std::snprintf(text, sizeof text, "%.17g,%.17g,%.17g,%.17g,%.17g,%.17g", p.latDegrees,
                p.lonDegrees, p.altitudeMeters, p.headingDegrees, p.pitchDegrees, p.rollDegrees);
  return text;
}

/// The window and GLFW, released in the right order on every path out.
struct Window final {
  GLFWwindow* handle = nullptr;
  bool glfw = false;
  Window() = default;
  Window(const Window&) = delete;
  Window& operator=(const Window&) = delete;
  ~Window() {
    if (handle != nullptr) glfwDestroyWindow(handle);
    if (glfw) glfwTerminate();
  }
};

/// What GLFW reported last (its error callback), for messages.
std::string& glfwLastError() {
  static std::string text;
  return text;
}

/// Input from the window, turned into control calls (GLFW's callbacks reach it through the
/// window's user pointer).
struct WindowInput final {
  FlyControls* controls = nullptr;
  bool dragging = false;
  double lastX = 0.0;
  double lastY = 0.0;
};

std::optional<FlyKey> keyOf(int glfwKey) {
  switch (glfwKey) {
    case GLFW_KEY_W:
      return FlyKey::W;
    case GLFW_KEY_A:
      return FlyKey::A;
    case GLFW_KEY_S:
      return FlyKey::S;
    case GLFW_KEY_D:
      return FlyKey::D;
    case GLFW_KEY_Q:
      return FlyKey::Q;
    case GLFW_KEY_E:
      return FlyKey::E;
    case GLFW_KEY_R:
      return FlyKey::R;
    case GLFW_KEY_F:
      return FlyKey::F;
    case GLFW_KEY_UP:
      return FlyKey::Up;
    case GLFW_KEY_DOWN:
      return FlyKey::Down;
    case GLFW_KEY_LEFT:
      return FlyKey::Left;
    case GLFW_KEY_RIGHT:
      return FlyKey::Right;
    case GLFW_KEY_M:
      return FlyKey::M;
    case GLFW_KEY_V:
      return FlyKey::V;
    case GLFW_KEY_H:
      return FlyKey::H;
    case GLFW_KEY_P:
      return FlyKey::P;
    case GLFW_KEY_G:
      return FlyKey::G;
    case GLFW_KEY_F1:
      return FlyKey::F1;
    case GLFW_KEY_ENTER:
    case GLFW_KEY_KP_ENTER:
      return FlyKey::Enter;
    case GLFW_KEY_ESCAPE:
      return FlyKey::Escape;
    case GLFW_KEY_BACKSPACE:
      return FlyKey::Backspace;
    case GLFW_KEY_LEFT_BRACKET:
      return FlyKey::BracketLeft;
    case GLFW_KEY_RIGHT_BRACKET:
      return FlyKey::BracketRight;
    default:
      return std::nullopt;
  }
}

void installCallbacks(GLFWwindow* window, WindowInput& input) {
  glfwSetWindowUserPointer(window, &input);
  glfwSetKeyCallback(window, [](GLFWwindow* w, int key, int, int action, int) {
    auto* in = static_cast<WindowInput*>(glfwGetWindowUserPointer(w));
    const std::optional<FlyKey> k = keyOf(key);
    if (!k) return;
    if (action == GLFW_PRESS) in->controls->press(*k);
    if (action == GLFW_RELEASE) in->controls->release(*k);
  });
  glfwSetCharCallback(window, [](GLFWwindow* w, unsigned int codepoint) {
    auto* in = static_cast<WindowInput*>(glfwGetWindowUserPointer(w));
    // G's entry: typing G itself opens it, so that letter is not part of the place.
    if (codepoint < 128 && codepoint != 'g' && codepoint != 'G') {
      const char c = static_cast<char>(codepoint);
      in->controls->type(std::string_view(&c, 1));
    }
  });
  glfwSetMouseButtonCallback(window, [](GLFWwindow* w, int button, int action, int) {
    auto* in = static_cast<WindowInput*>(glfwGetWindowUserPointer(w));
    if (button != GLFW_MOUSE_BUTTON_LEFT) return;
    in->dragging = action == GLFW_PRESS;
    glfwGetCursorPos(w, &in->lastX, &in->lastY);
  });
  glfwSetCursorPosCallback(window, [](GLFWwindow* w, double x, double y) {
    auto* in = static_cast<WindowInput*>(glfwGetWindowUserPointer(w));
    if (!in->dragging) return;
    in->controls->drag(x - in->lastX, y - in->lastY);
    in->lastX = x;
    in->lastY = y;
  });
  glfwSetScrollCallback(window, [](GLFWwindow* w, double, double dy) {
    auto* in = static_cast<WindowInput*>(glfwGetWindowUserPointer(w));
    in->controls->wheel(dy);
  });
}

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

class FlySession final {
 public:
  FlySession(const FlyCliOptions& c, const FlyModes& modes, std::shared_ptr<MappedDataset> dataset,
             gpu::VulkanContext& context, GLFWwindow* window)
      : c_(c),
        modes_(modes),
        dataset_(std::move(dataset)),
        view_(dataset_->view()),
        context_(context),
        window_(window) {}

  int run(FlyControls& controls, FlyScriptDriver& driver);

 private:
  Result<void> setUp();
  Result<void> drain();
  Result<void> collectOne();
  Result<void> resizeTo(std::uint32_t width, std::uint32_t height);
  std::vector<std::string> hudLines(const FlyControls& controls, double fps) const;
  /// The light of the frame at `t` as `pbdam render` options, for a screenshot's side file.
  std::string lightOptionsText(const FlyControls& controls, double t) const;
  Result<void> frame(FlyControls& controls, double t);
  int finish(int status);

  const FlyCliOptions& c_;
  const FlyModes& modes_;
  std::shared_ptr<MappedDataset> dataset_;  ///< the terrain's, and the HUD's view
  const DatasetView& view_;
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
  std::vector<CameraPathPoint> recorded_;
  std::size_t frames_ = 0;
  std::size_t shotsTaken_ = 0;
  bool viewshedOn_ = false;
  std::optional<Camera> lightTarget_;  // the first frame's camera: a placed sun stands over it
  std::string sunLine_;                // the light, for the HUD
  gpu::FrameSettings settings_;
  bool recreate_ = false;
};

Result<void> FlySession::setUp() {
  int fbw = 0;
  int fbh = 0;
  glfwGetFramebufferSize(window_, &fbw, &fbh);
  auto swapchain =
      gpu::Swapchain::create(context_, static_cast<std::uint32_t>(std::max(fbw, 1)),
                             static_cast<std::uint32_t>(std::max(fbh, 1)), modes_.present);
  if (!swapchain) return swapchain.error();
  swapchain_ = std::move(*swapchain);
  // The terrain as bench runs it: no-stall keeps the coarse levels locked and holds each cut's
  // pages until decoded under a budget; the memory plan is printed when it changed anything.
  const bool noStall = modes_.mode == StreamingMode::NoStall;
  gpu::TerrainOptions options;
  options.mode = noStall ? gpu::TerrainMode::NoStall
                         : (modes_.prefetch ? gpu::TerrainMode::Paging : gpu::TerrainMode::Exact);
  options.refinement.tolerancePixels = c_.tolerancePixels;
  options.refinement.morphRange = morphRangeOf(c_.morph, modes_.morph);
  options.refinement.exaggeration = c_.exaggeration;
  options.prefetch = modes_.prefetch;
  options.lookaheadSeconds = c_.lookahead;
  options.gpuCacheBytes = static_cast<std::uint64_t>(c_.gpuCacheMiB * 1048576.0);
  options.memoryBudgetMiB = c_.memoryBudgetMiB;
  options.reportMemoryPlan = true;
  options.viewport = Viewport{swapchain_.extent().width, swapchain_.extent().height, c_.fovDegrees};
  options.framesInFlight = c_.framesInFlight;
  options.atmosphere = atmosphereTablesFor(modes_.light, view_.planet(), false);
  auto terrain = gpu::Terrain::open(context_, dataset_, std::move(options));
  if (!terrain) return terrain.error();
  terrain_ = std::move(*terrain);
  for (const Error& e : terrain_->preloadSkipped()) {
    std::fprintf(stderr, "pbdam: warning: preload skipped: %s\n", e.message.c_str());
  }
  // One acquisition semaphore (and HUD buffer) more than frames in flight: the one a new frame
  // takes was waited for by a frame that has been collected.
  const std::size_t ring = c_.framesInFlight + 1;
  for (std::size_t i = 0; i < ring; ++i) {
    VkSemaphoreCreateInfo info{};
    info.sType = VK_STRUCTURE_TYPE_SEMAPHORE_CREATE_INFO;
    VkSemaphore semaphore = VK_NULL_HANDLE;
    if (VkResult r = vkCreateSemaphore(context_.device(), &info, nullptr, &semaphore);
        r != VK_SUCCESS) {
      return makeError(ErrorCode::DeviceError, "vkCreateSemaphore (fly)");
    }
    acquired_.emplace_back(context_.device(), semaphore);
  }
  hud_.buffers.resize(ring);
  hud_.sizes.assign(ring, 0);
  return {};
}

Result<void> FlySession::collectOne() {
  auto frame = terrain_->collect();
  if (!frame) return frame.error();
  const InFlight done = inFlight_.front();
  inFlight_.pop_front();
  figures_.last = frame->stats;
  figures_.lastTraversalMs = done.traversalMs;
  figures_.drawMs.push_back(frame->stats.drawMs);
  if (done.screenshot) {
    if (auto r = writer_.write(*done.screenshot, std::move(frame->image)); !r) return r;
    ++figures_.screenshots;
  }
  return {};
}

Result<void> FlySession::drain() {
  while (!inFlight_.empty()) {
    if (auto r = collectOne(); !r) return r;
  }
  return {};
}

Result<void> FlySession::resizeTo(std::uint32_t width, std::uint32_t height) {
  if (auto r = drain(); !r) return r;
  if (auto r = swapchain_.recreate(width, height); !r) return r;
  recreate_ = false;
  return terrain_->resize(swapchain_.extent().width, swapchain_.extent().height);
}

std::string FlySession::lightOptionsText(const FlyControls& controls, double t) const {
  // The light of this frame as `render` options: the sun's instant (to the millisecond), or the
  // hand-placed sun's azimuth and elevation (over this render's own target), the air and the
  // exaggeration.
  const Light& light = modes_.light;
  std::ostringstream text;
  if (light.kind == Light::Kind::Ephemeris) {
    text << " --time "
         << runtime::formatUtcTime(light.unixSeconds + controls.sunHours * 3600.0 +
                                   light.timeScale * t);
  } else if (light.kind == Light::Kind::Horizon) {
    text << " --sun " << light.azimuthDegrees << "," << light.elevationDegrees;
  }
  text << " --ambient " << light.ambient << " --atmosphere "
       << (atmosphereOn(light, view_.planet()) ? "on" : "off");
  if (light.exposure) text << " --exposure " << *light.exposure;
  if (c_.exaggeration != 1.0) text << " --exaggeration " << c_.exaggeration;
  return text.str();
}

std::vector<std::string> FlySession::hudLines(const FlyControls& controls, double fps) const {
  std::vector<std::string> lines;
  char line[256];
  const gpu::FrameStats& s = figures_.last;
  std::snprintf(line, sizeof line, "%.1f fps  frame %.1f ms  draw %.1f ms  traversal %.2f ms", fps,
                figures_.frameMs.empty() ? 0.0 : figures_.frameMs.back(), s.drawMs,
                figures_.lastTraversalMs);
  lines.emplace_back(line);
  std::snprintf(line, sizeof line, "%llu triangles  %llu patches  %llu tiles",
                static_cast<unsigned long long>(s.triangles),
                static_cast<unsigned long long>(s.patches),
                static_cast<unsigned long long>(s.tiles));
  lines.emplace_back(line);
  std::snprintf(line, sizeof line, "GPU cache %.1f / %.0f MiB  faults %llu  data stalls %zu",
                static_cast<double>(terrain_->renderer().residentBytes()) / 1048576.0,
                static_cast<double>(terrain_->gpuCacheBytes()) / 1048576.0,
                static_cast<unsigned long long>(figures_.faults), figures_.dataStalls);
  lines.emplace_back(line);
  const CameraPose& p = controls.pose();
  std::snprintf(line, sizeof line, "lat %.5f  lon %.5f  alt %.0f m  ground %.0f m", p.latDegrees,
                p.lonDegrees, p.altitudeMeters, controls.groundMeters());
  lines.emplace_back(line);
  std::snprintf(line, sizeof line, "heading %.1f  pitch %.1f  morph %s  %s%s", p.headingDegrees,
                p.pitchDegrees, controls.morph ? "on" : "off", toString(modes_.mode),
                controls.viewshed ? "  viewshed" : "");
  lines.emplace_back(line);
  if (!sunLine_.empty()) lines.push_back(sunLine_);
  if (controls.typing) lines.push_back("go to LAT,LON: " + controls.typed + "_");
  if (!controls.message.empty()) lines.push_back(controls.message);
  if (controls.help) {
    for (const char* help :
         {"W/S or up/down: forward/back   A/D: sideways", "left/right or drag: turn and look",
          "Q/E or wheel: height   R/F: pitch", "M: morph   V: viewshed below   P: screenshot",
          "G: go to LAT,LON (Enter)   H: this display   F1: help",
          "[ ]: the sun's time an hour back / on (with --time)"}) {
      lines.emplace_back(help);
    }
  } else {
    lines.emplace_back("F1: help");
  }
  return lines;
}

Result<void> FlySession::frame(FlyControls& controls, double t) {
  const Viewport viewport{swapchain_.extent().width, swapchain_.extent().height, c_.fovDegrees};
  const Camera camera = Camera::fromPose(view_.planet(), controls.pose(), viewport);
  if (controls.viewshed != viewshedOn_) {
    viewshedOn_ = controls.viewshed;
    settings_.overlay.reset();
    if (viewshedOn_) {
      ViewshedRequest request{controls.pose().latDegrees, controls.pose().lonDegrees, 10.0, {}, {}};
      auto viewshed = terrain_->viewshed(request);
      if (!viewshed) {
        controls.message = "viewshed: " + viewshed.error().message;
        controls.viewshed = viewshedOn_ = false;
      } else {
        settings_.overlay = viewshedOverlay(*viewshed);
      }
    }
  }
  RefinementOptions refinement;
  refinement.tolerancePixels = c_.tolerancePixels;
  refinement.morphRange = morphRangeOf(c_.morph, controls.morph);
  refinement.exaggeration = c_.exaggeration;
  if (auto r = terrain_->setRefinement(refinement); !r) return r;

  if (!lightTarget_) lightTarget_ = camera;
  Light light = modes_.light;
  light.unixSeconds += controls.sunHours * 3600.0;
  applyLight(light, view_.planet(), *lightTarget_, t, settings_);
  sunLine_ = describeLight(light, view_.planet(), *lightTarget_, t);

  const std::uint64_t faults0 = threadMajorFaults();
  const auto t0 = Clock::now();
  InFlight entry;
  entry.frame = frames_;
  // A screenshot is the exact-mode frame `pbdam render` draws for this camera.
  const bool screenshot = controls.screenshotsWanted > 0;
  auto selected = terrain_->update(camera, t, screenshot);
  if (!selected) return selected.error();
  entry.traversalMs = std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
  if (screenshot) {
    --controls.screenshotsWanted;
    char name[32];
    std::snprintf(name, sizeof name, "_%03zu.png", shotsTaken_++);
    entry.screenshot = c_.screenshots + name;
    std::ofstream side(*entry.screenshot + ".txt");
    side << "--camera " << poseText(controls.pose()) << " --width " << viewport.width
         << " --height " << viewport.height << " --fov-deg " << c_.fovDegrees << " --tolerance-px "
         << c_.tolerancePixels << " --morph " << (controls.morph ? "on" : "off")
         << " --morph-range " << c_.morph.range << lightOptionsText(controls, t) << "\n";
    std::printf("screenshot %s camera %s\n", entry.screenshot->c_str(),
                poseText(controls.pose()).c_str());
    std::fflush(stdout);
  }

  const std::size_t slot = frames_ % acquired_.size();
  auto image = swapchain_.acquire(acquired_[slot].get());
  if (!image) return image.error();
  if (!*image) {  // out of date: a new swapchain first
    recreate_ = true;
    if (screenshot) ++controls.screenshotsWanted;
    return {};
  }
  gpu::PresentTarget present;
  present.image = (*image)->image;
  present.extent = (*image)->extent;
  present.acquired = (*image)->acquired;
  present.rendered = (*image)->rendered;
  if (controls.hud) {
    if (secondsBetween(hudDrawn_, Clock::now()) > 0.25 || hudPixels_.bytes.empty()) {
      const double fps =
          figures_.frameMs.empty() ? 0.0 : 1000.0 / std::max(1e-3, figures_.frameMs.back());
      hudPixels_ = drawHud(hudLines(controls, fps), swapchain_.format() == VK_FORMAT_B8G8R8A8_UNORM,
                           std::min<std::uint32_t>(present.extent.width, 640));
      hudDrawn_ = Clock::now();
    }
    const std::uint64_t bytes = hudPixels_.bytes.size();
    if (bytes > 0) {
      if (hud_.sizes[slot] < bytes) {
        auto buffer = gpu::createBuffer(context_, bytes, VK_BUFFER_USAGE_TRANSFER_SRC_BIT,
                                        gpu::MemoryUse::HostUpload, "fly HUD");
        if (!buffer) return buffer.error();
        hud_.buffers[slot] = std::move(*buffer);
        hud_.sizes[slot] = bytes;
      }
      std::memcpy(hud_.buffers[slot].mappedBytes().data(), hudPixels_.bytes.data(), bytes);
      if (auto r = hud_.buffers[slot].flushHostWrites(); !r) return r;
      present.overlay = hud_.buffers[slot].buffer();
      present.overlayOffset = {8, 8};
      present.overlayExtent = {hudPixels_.width, hudPixels_.height};
    }
  }
  gpu::FrameSettings frame = settings_;
  frame.readback = screenshot;
  frame.present = present;
  if (auto submitted = terrain_->submit(frame); !submitted) return submitted;
  entry.faults = threadMajorFaults() - faults0;
  inFlight_.push_back(entry);
  auto shown = swapchain_.present(**image);
  if (!shown) return shown.error();
  if (!*shown) recreate_ = true;
  while (inFlight_.size() >= terrain_->renderer().framesInFlight()) {
    if (auto r = collectOne(); !r) return r;
  }
  figures_.faults += entry.faults;
  if (frames_ > 0) figures_.faultsAfterFirst += entry.faults;
  ++frames_;
  return {};
}

int FlySession::run(FlyControls& controls, FlyScriptDriver& driver) {
  if (auto r = setUp(); !r) return reportError(r.error());
  WindowInput input;
  input.controls = &controls;
  installCallbacks(window_, input);
  const auto start = Clock::now();
  auto last = start;        // the end of the last frame shown
  auto lastUpdate = start;  // the time the controls were last advanced to
  bool open = true;
  const std::function<void(int, int)> resizeWindow = [this](int width, int height) {
    glfwSetWindowSize(window_, width, height);
  };
  while (open && glfwWindowShouldClose(window_) == GLFW_FALSE) {
    glfwPollEvents();
    const auto now = Clock::now();
    const double t = secondsBetween(start, now);
    const auto advanceTo = [&](double eventSeconds) {
      const auto at = start + std::chrono::duration_cast<Clock::duration>(
                                  std::chrono::duration<double>(eventSeconds));
      if (at <= lastUpdate) return;
      controls.update(secondsBetween(lastUpdate, at));
      lastUpdate = at;
    };
    if (!driver.applyScript(t, controls, resizeWindow, advanceTo)) open = false;
    if (c_.exitAfterSeconds > 0.0 && t >= c_.exitAfterSeconds) open = false;
    if (!driver.applyReplay(t, controls)) open = false;
    if (!open) break;
    int fbw = 0;
    int fbh = 0;
    glfwGetFramebufferSize(window_, &fbw, &fbh);
    if (fbw <= 0 || fbh <= 0) {  // minimised: nothing to draw into
      glfwWaitEventsTimeout(0.1);
      last = lastUpdate = Clock::now();
      continue;
    }
    const auto width = static_cast<std::uint32_t>(fbw);
    const auto height = static_cast<std::uint32_t>(fbh);
    if (recreate_ || width != swapchain_.extent().width || height != swapchain_.extent().height) {
      if (auto r = resizeTo(width, height); !r) return finish(reportError(r.error()));
      last = lastUpdate = Clock::now();
      continue;
    }
    controls.update(secondsBetween(lastUpdate, now));
    lastUpdate = now;
    const double frameStart = t;
    if (auto r = frame(controls, t); !r) return finish(reportError(r.error()));
    const auto end = Clock::now();
    const double ms = std::chrono::duration<double, std::milli>(end - last).count();
    last = end;
    figures_.frameMs.push_back(ms);
    figures_.frameStartS.push_back(frameStart);
    // A data stall as bench counts it, against the median of the last 120 frames (a window,
    // so that the per-frame cost does not grow with the flight).
    const std::size_t window = std::min<std::size_t>(figures_.frameMs.size(), 120);
    const double median =
        percentile(std::vector<double>(figures_.frameMs.end() - static_cast<std::ptrdiff_t>(window),
                                       figures_.frameMs.end()),
                   0.5);
    if (!figures_.drawMs.empty() && ms - figures_.drawMs.back() > median &&
        figures_.frameMs.size() > 1) {
      ++figures_.dataStalls;
    }
    if (!c_.record.empty()) {
      const CameraPose& p = controls.pose();
      double rowT = t;
      if (!recorded_.empty() && rowT <= recorded_.back().tSeconds) {
        rowT = std::nextafter(recorded_.back().tSeconds, 1e300);
      }
      recorded_.push_back({rowT, p.latDegrees, p.lonDegrees, p.altitudeMeters, p.headingDegrees,
                           p.pitchDegrees, p.rollDegrees});
    }
  }
  return finish(kExitOk);
}

int FlySession::finish(int status) {
  if (auto r = drain(); !r && status == kExitOk) status = reportError(r.error());
  if (auto r = writer_.finish(); !r && status == kExitOk) status = reportError(r.error());
  if (terrain_) terrain_->stopPrefetcher();
  (void)context_.waitIdle();
  if (!c_.record.empty() && !recorded_.empty()) {
    if (auto r = writeCameraPath(c_.record, recorded_); !r && status == kExitOk) {
      status = reportError(r.error());
    }
  }
  // Frame times after the first second: the first frames decode the coarse levels.
  std::vector<double> steady;
  for (std::size_t i = 0; i < figures_.frameMs.size(); ++i) {
    if (figures_.frameStartS[i] >= 1.0) steady.push_back(figures_.frameMs[i]);
  }
  const double seconds =
      std::accumulate(figures_.frameMs.begin(), figures_.frameMs.end(), 0.0) / 1000.0;
  nlohmann::ordered_json j;
  j["frames"] = figures_.frameMs.size();
  j["seconds"] = seconds;
  j["fps_mean"] = seconds > 0.0 ? static_cast<double>(figures_.frameMs.size()) / seconds : 0.0;
  j["frame_ms_p50"] = percentile(figures_.frameMs, 0.5);
  j["frame_ms_p99"] = percentile(figures_.frameMs, 0.99);
  j["frame_ms_max"] = figures_.frameMs.empty()
                          ? 0.0
                          : *std::max_element(figures_.frameMs.begin(), figures_.frameMs.end());
  j["frame_ms_p99_after_1s"] = percentile(steady, 0.99);
  j["frame_ms_max_after_1s"] =
      steady.empty() ? 0.0 : *std::max_element(steady.begin(), steady.end());
  j["draw_ms_p50"] = percentile(figures_.drawMs, 0.5);
  j["render_thread_major_faults"] = figures_.faults;
  j["render_thread_major_faults_after_first_frame"] = figures_.faultsAfterFirst;
  j["data_stalls"] = figures_.dataStalls;
  j["screenshots"] = figures_.screenshots;
  j["mode"] = toString(modes_.mode);
  j["prefetch"] = onOff(modes_.prefetch);
  j["present"] = gpu::toString(swapchain_.mode());
  j["frames_in_flight"] = c_.framesInFlight;
  j["width"] = swapchain_.extent().width;
  j["height"] = swapchain_.extent().height;
  j["device"] = context_.deviceInfo().name;
  std::printf(
      "fly: %zu frames in %.1f s (%.1f fps), frame p50 %.1f ms, p99 %.1f ms; after the "
      "first second max %.1f ms; render-thread faults %llu, data stalls %zu\n",
      figures_.frameMs.size(), seconds, j["fps_mean"].get<double>(),
      j["frame_ms_p50"].get<double>(), j["frame_ms_p99"].get<double>(),
      j["frame_ms_max_after_1s"].get<double>(), static_cast<unsigned long long>(figures_.faults),
      figures_.dataStalls);
  if (!c_.stats.empty()) {
    std::ofstream out(c_.stats);
    out << j.dump(2) << "\n";
    if (!out && status == kExitOk) status = badInput(c_.stats + ": write failed");
  }
  return status;
}

int runFly(const FlyCliOptions& c) {
  FlyModes modes;
  if (const int status = checkFlyOptions(c, modes); status != kExitOk) return status;
  // Everything about the data first: nothing opens a window for a dataset that cannot be read.
  auto opened = MappedDataset::open(c.dir, faceOptionsFor(memoryLimitOf(c.memoryBudgetMiB)));
  if (!opened) return reportError(opened.error());
  // Shared: the controls' ground heights read it beside the session's terrain.
  const std::shared_ptr<MappedDataset> dataset = std::move(*opened);
  const DatasetView& view = dataset->view();
  if (auto r = checkMorphOptions(c.morph, view, false); !r) return reportError(r.error());
  modes.morph = c.morph.morph == "on";
  if (auto r = checkLightFor(modes.light, view.planet()); !r) return reportError(r.error());
  auto driver = FlyScriptDriver::load(c.script, c.replay);
  if (!driver) return reportError(driver.error());
  const Planet& planet = view.planet();
  CameraPose start{0.0, 0.0, 2.0 * planet.equatorialRadiusMeters(), 0.0, -90.0, 0.0};
  if (!c.camera.empty()) {
    auto pose = parseCameraPose(c.camera);
    if (!pose) return reportError(pose.error());
    start = *pose;
  } else if (const std::optional<CameraPose> replayStart = driver->replayStart()) {
    start = *replayStart;
  }
  if (auto r = validateCameraPose(start, planet); !r) return reportError(r.error());
  std::optional<std::vector<double>> goTo;
  if (!c.goTo.empty()) {
    std::vector<double> latLon;
    if (!parseNumberList(c.goTo, 2, latLon)) {
      return badInput("--goto '" + c.goTo + "': expected LAT,LON in degrees");
    }
    goTo = latLon;
  }

  const char* display = std::getenv("DISPLAY");
  const char* wayland = std::getenv("WAYLAND_DISPLAY");
  if ((display == nullptr || *display == '\0') && (wayland == nullptr || *wayland == '\0')) {
    return badInput(
        "no display: neither DISPLAY nor WAYLAND_DISPLAY is set (run it in a desktop session, "
        "or under xvfb-run for a window nobody sees)");
  }
  Window window;
  glfwSetErrorCallback([](int, const char* text) { glfwLastError() = text; });
  if (glfwInit() == GLFW_FALSE) {
    return badInput("cannot open a window on this display: " + glfwLastError());
  }
  window.glfw = true;
  if (glfwVulkanSupported() == GLFW_FALSE) {
    std::cerr << "pbdam: the window system offers no Vulkan surfaces (GLFW: " << glfwLastError()
              << ")\n";
    return kExitFailure;
  }
  glfwWindowHint(GLFW_CLIENT_API, GLFW_NO_API);
  GLFWmonitor* monitor = c.fullscreen ? glfwGetPrimaryMonitor() : nullptr;
  int width = static_cast<int>(c.width);
  int height = static_cast<int>(c.height);
  if (monitor != nullptr) {
    const GLFWvidmode* mode = glfwGetVideoMode(monitor);
    width = mode->width;
    height = mode->height;
  }
  const std::string title = "pbdam fly — " + fs::path(c.dir).filename().string();
  window.handle = glfwCreateWindow(width, height, title.c_str(), monitor, nullptr);
  if (window.handle == nullptr) {
    std::cerr << "pbdam: cannot create the window: " << glfwLastError() << "\n";
    return kExitFailure;
  }

  gpu::ContextOptions options;
  options.device = c.device;
  options.enableValidation = c.validation || gpu::kValidationByDefault;
  gpu::WindowPresentation presentation;
  std::uint32_t extensionCount = 0;
  const char** extensions = glfwGetRequiredInstanceExtensions(&extensionCount);
  for (std::uint32_t i = 0; i < extensionCount; ++i) {
    presentation.instanceExtensions.emplace_back(extensions[i]);
  }
  GLFWwindow* handle = window.handle;
  presentation.createSurface = [handle](VkInstance instance) -> Result<VkSurfaceKHR> {
    VkSurfaceKHR surface = VK_NULL_HANDLE;
    if (VkResult r = glfwCreateWindowSurface(instance, handle, nullptr, &surface);
        r != VK_SUCCESS) {
      return makeError(ErrorCode::DeviceError,
                       "cannot make a Vulkan surface for the window: " + glfwLastError());
    }
    return surface;
  };
  options.presentation = std::move(presentation);
  int status = kExitOk;
  {
    auto context = gpu::VulkanContext::create(options);
    if (!context) return reportError(context.error());
    SurfaceLeafCache leaves;
    FlyControls controls(start, planet.equatorialRadiusMeters(),
                         [&view, &leaves, &c](double lat, double lon) -> std::optional<double> {
                           auto h = surfaceHeightAt(view, lat, lon, leaves);
                           if (!h) return std::nullopt;
                           // The ground drawn: exaggerated like the terrain.
                           return h->heightMeters * c.exaggeration;
                         });
    controls.morph = modes.morph;
    if (goTo) {
      if (auto r = controls.goTo((*goTo)[0], (*goTo)[1]); !r) return reportError(r.error());
    }
    {
      FlySession session(c, modes, dataset, *context, window.handle);
      status = session.run(controls, *driver);
    }
    if (c.validation && context->validationLog().count() > 0) {
      std::cerr << "pbdam: " << context->validationLog().count() << " Vulkan validation messages\n";
      if (status == kExitOk) status = kExitFailure;
    }
  }
  return status;
}

}  // namespace

void addFlyCommand(CLI::App& app, CommandStatus& status) {
  auto o = std::make_shared<FlyCliOptions>();
  CLI::App* fly = app.add_subcommand(
      "fly",
      "Fly over a dataset in a window: WASD/arrows, drag, wheel or Q/E, R/F, M, V, G, P, H, [ ], "
      "F1 "
      "(F1 in the window lists them); record the flight as a camera path, replay one, or drive "
      "it with a script");
  fly->add_option("DIR", o->dir, "Dataset directory (pbdam build --out)")->required();
  fly->add_option("--width", o->width, "Window width in pixels")->capture_default_str();
  fly->add_option("--height", o->height, "Window height in pixels")->capture_default_str();
  fly->add_flag("--fullscreen", o->fullscreen, "Full screen on the primary monitor");
  fly->add_option("--device", o->device, kDeviceOptionHelp);
  fly->add_option("--tolerance-px", o->tolerancePixels, "Screen-space error tolerance in pixels")
      ->capture_default_str();
  fly->add_option("--fov-deg", o->fovDegrees, "Vertical field of view in degrees")
      ->capture_default_str();
  addMorphOptions(*fly, o->morph, false);
  addExaggerationOption(*fly, o->exaggeration);
  addLightOptions(*fly, o->light, true);
  fly->add_option("--camera", o->camera,
                  "Start pose LAT,LON,ALT[,HEADING,PITCH,ROLL] (default: the whole planet from "
                  "twice its radius)");
  fly->add_option("--goto", o->goTo, "LAT,LON: start over this place at the start pose's height");
  fly->add_option("--gpu-cache-mib", o->gpuCacheMiB, "GPU cache budget in MiB")
      ->capture_default_str();
  fly->add_option("--memory-budget-mib", o->memoryBudgetMiB,
                  "Memory the flight may use in MiB (0: the memory cgroup's limit, if any): the "
                  "GPU cache (on a CPU device) is lowered to leave room for the dataset's pages")
      ->capture_default_str();
  fly->add_option("--present", o->present,
                  "fifo (wait for the display, never tears), mailbox or immediate (to measure)")
      ->capture_default_str();
  fly->add_option("--mode", o->mode,
                  "no-stall: draw the finest resident cut, never wait on the disk; paging: "
                  "exact cuts, missing pages fault in on the render thread")
      ->capture_default_str();
  fly->add_option("--prefetch", o->prefetch, "on: madvise the predicted camera's data ahead")
      ->capture_default_str();
  fly->add_option("--lookahead-s", o->lookahead, "Prefetch look-ahead in seconds")
      ->capture_default_str();
  fly->add_option("--frames-in-flight", o->framesInFlight, kFramesInFlightHelp)
      ->capture_default_str();
  fly->add_option("--record", o->record,
                  "Write the flown path, one row a shown frame, as camera-path CSV "
                  "(pbdam bench --path, pbdam render --path)");
  fly->add_option("--replay", o->replay, "Fly a camera-path CSV in the window, then exit");
  fly->add_option("--script", o->script,
                  "Timed input events, one a line: T key NAME [down|up], T drag DX DY, T wheel N, "
                  "T type TEXT, T resize W H, T close");
  fly->add_option("--exit-after-s", o->exitAfterSeconds, "Close after this many seconds (0: never)")
      ->capture_default_str();
  fly->add_option("--screenshots", o->screenshots,
                  "Prefix of P's screenshots: PREFIX_000.png... (exact mode, the bytes pbdam "
                  "render writes; the camera and options beside each in PREFIX_000.png.txt)")
      ->capture_default_str();
  fly->add_option("--stats", o->stats, "Write the flight's figures as JSON to this file");
  fly->add_flag("--validation", o->validation,
                "Khronos validation on; any message makes the exit status 1");
  fly->callback([o, &status] { status.exitCode = runFly(*o); });
}

}  // namespace pbdam::tools
