// The frame loop of `pbdam fly` (FlySession.h): each frame is drawn offscreen by the Terrain
// with frames in flight, exactly as `pbdam render` draws it, and copied into the acquired
// swapchain image by the frame's own submission with the heads-up display over it; screenshots
// are the exact-mode frames `pbdam render` writes, and the flight's figures are printed at the end.
#include "FlySession.h"

#include <GLFW/glfw3.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <functional>
#include <nlohmann/json.hpp>
#include <numeric>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

#include "BenchReport.h"
#include "Commands.h"
#include "ViewshedOutput.h"
#include "pbdam/gpu/GpuViewshed.h"
#include "pbdam/runtime/Sun.h"
#include "pbdam/streaming/NoStallPolicy.h"
#include "pbdam/streaming/ProcessMemory.h"

using namespace pbdam::formats;
using namespace pbdam::runtime;
using namespace pbdam::streaming;
using namespace pbdam::gpu;

namespace pbdam::tools::fly_internal {
namespace {

using Clock = FlySession::Clock;

double secondsBetween(Clock::time_point a, Clock::time_point b) {
  return std::chrono::duration<double>(b - a).count();
}

std::string poseText(const CameraPose& p) {
  char text[256];
  std::snprintf(text, sizeof text, "%.17g,%.17g,%.17g,%.17g,%.17g,%.17g", p.latDegrees,
                p.lonDegrees, p.altitudeMeters, p.headingDegrees, p.pitchDegrees, p.rollDegrees);
  return text;
}

}  // namespace

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

}  // namespace pbdam::tools::fly_internal
