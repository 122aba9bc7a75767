// `pbdam fly`: an interactive flythrough in a window (GLFW on X11, Vulkan WSI). This file holds
// the command line, the window and its input, and opens the dataset, the window and the device
// for the flight; FlySession.h draws the frames: offscreen by the TerrainRenderer with frames in
// flight, exactly as `pbdam render` draws them, copied into the window with the heads-up display
// over them (FlyHud.h). The controls (FlyControls.h) move the camera; no-stall mode with prefetch
// from the live camera keeps the render thread off the disk. The flight can be recorded as a
// camera path (`pbdam bench`, `pbdam render --path`), replayed, and driven by a script of timed
// events (tests): FlyScriptDriver.h.
#define GLFW_INCLUDE_VULKAN
#include <GLFW/glfw3.h>

#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <iostream>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "Commands.h"
#include "ExaggerationOption.h"
#include "FlyControls.h"
#include "FlyScriptDriver.h"
#include "FlySession.h"
#include "LightOption.h"
#include "MorphOption.h"
#include "pbdam/formats/NumberList.h"
#include "pbdam/gpu/FrameModes.h"
#include "pbdam/gpu/Swapchain.h"
#include "pbdam/gpu/TerrainRenderer.h"
#include "pbdam/gpu/VulkanContext.h"
#include "pbdam/runtime/Camera.h"
#include "pbdam/runtime/SurfaceQuery.h"
#include "pbdam/streaming/MappedDataset.h"
#include "pbdam/streaming/MemoryBudget.h"

using namespace pbdam::formats;
using namespace pbdam::runtime;
using namespace pbdam::streaming;
using namespace pbdam::gpu;

namespace pbdam::tools {

using namespace fly_internal;

int fly_internal::badInput(const std::string& message) {
  std::cerr << "pbdam: " << message << "\n";
  return kExitBadInput;
}

namespace {

namespace fs = std::filesystem;

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

}  // namespace

void fly_internal::installCallbacks(GLFWwindow* window, WindowInput& input) {
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

namespace {

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
