// `pbdam render`: exact-mode frames of a dataset (docs/architecture.md "What pbdam is", "Refinement
// and drawing") from one camera or a camera path, written as PNG/EXR, with per-frame statistics as
// JSON lines and an MP4 through ffmpeg when it is installed.
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <deque>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <memory>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include "Commands.h"
#include "ExaggerationOption.h"
#include "FocusOption.h"
#include "FrameImage.h"
#include "FrameWriter.h"
#include "LightOption.h"
#include "MorphOption.h"
#include "Progress.h"
#include "ViewshedOutput.h"
#include "ViewshedSpec.h"
#include "pbdam/formats/CameraPath.h"
#include "pbdam/formats/NumberList.h"
#include "pbdam/gpu/FrameModes.h"
#include "pbdam/gpu/Terrain.h"
#include "pbdam/gpu/TerrainRenderer.h"
#include "pbdam/gpu/VulkanContext.h"
#include "pbdam/runtime/Camera.h"
#include "pbdam/runtime/Refinement.h"
#include "pbdam/runtime/Selection.h"
#include "pbdam/streaming/MappedDataset.h"
#include "pbdam/streaming/MemoryBudget.h"

extern char** environ;

using namespace pbdam::formats;
using namespace pbdam::runtime;
using namespace pbdam::streaming;
using namespace pbdam::gpu;

namespace pbdam::tools {
namespace {

namespace fs = std::filesystem;

/// The options as typed; --selection and --morph are parsed once into RenderModes.
struct RenderCliOptions {
  std::string dir;
  std::string camera;
  std::string path;
  std::string out;
  std::uint32_t width = 1280;
  std::uint32_t height = 720;
  double fovDegrees = 60.0;
  double tolerancePixels = 3.0;
  double gpuCacheMiB = 256.0;
  std::string device;
  std::string stats;
  std::string clear = "0,0,0";
  bool quiet = false;
  MorphCliOptions morph;
  double exaggeration = 1.0;
  FocusCliOptions focus;
  std::string viewshed;
  std::string selection = "cpu";
  std::uint32_t framesInFlight = 2;
  LightCliOptions light;
};

/// The frame loop's modes, parsed from RenderCliOptions when the options are checked.
struct RenderModes final {
  CutSelection selection = CutSelection::Cpu;
  bool morph = true;
  Light light;
};

int badInput(const std::string& message) {
  std::cerr << "pbdam: " << message << "\n";
  return kExitBadInput;
}

/// A frame to render: its pose and, for paths, its row.
struct FrameJob {
  CameraPose pose;
  double tSeconds = 0.0;
  fs::path out;
};

/// Whether an executable `name` is on PATH.
std::optional<fs::path> findOnPath(const std::string& name) {
  const char* path = std::getenv("PATH");
  if (path == nullptr) return std::nullopt;
  std::string_view rest(path);
  while (true) {
    const std::size_t colon = rest.find(':');
    const std::string dir(rest.substr(0, colon));
    const fs::path candidate = fs::path(dir.empty() ? "." : dir) / name;
    if (::access(candidate.c_str(), X_OK) == 0 && fs::is_regular_file(candidate)) {
      return candidate;
    }
    if (colon == std::string_view::npos) return std::nullopt;
    rest.remove_prefix(colon + 1);
  }
}

/// Runs `argv` (no shell) and returns its exit status, or -1 when it could not start.
int runProgram(const std::vector<std::string>& argv) {
  std::vector<char*> args;
  args.reserve(argv.size() + 1);
  for (const std::string& a : argv) args.push_back(const_cast<char*>(a.c_str()));
  args.push_back(nullptr);
  pid_t pid = 0;
  if (::posix_spawnp(&pid, args[0], nullptr, nullptr, args.data(), environ) != 0) return -1;
  int status = 0;
  while (::waitpid(pid, &status, 0) < 0) {
    if (errno != EINTR) return -1;
  }
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

std::string frameName(const fs::path& prefix, std::size_t index, const std::string& ext) {
  char number[32];
  std::snprintf(number, sizeof number, "_%06zu", index);
  return prefix.string() + number + ext;
}

nlohmann::ordered_json statsJson(std::size_t frame, double traversalMs, const gpu::FrameStats& s,
                                 const CutMorphSummary& morph) {
  nlohmann::ordered_json j;
  j["frame"] = frame;
  j["patches"] = s.patches;
  j["morphing_patches"] = morph.morphingPatches;
  j["blending_patches"] = morph.blendingPatches;
  j["largest_morph_weight"] = morph.largestWeight;
  j["triangles"] = s.triangles;
  j["tiles"] = s.tiles;
  j["traversal_ms"] = traversalMs;
  j["decode_ms"] = s.decodeMs;
  j["upload_ms"] = s.uploadMs;
  j["draw_ms"] = s.drawMs;
  j["frame_ms"] = s.frameMs;
  j["resident_bytes"] = s.residentBytes;
  j["hits"] = s.hits;
  j["misses"] = s.misses;
  j["evictions"] = s.evictions;
  j["bytes_uploaded"] = s.bytesUploaded;
  j["passes"] = s.passes;
  j["budget_exceeded"] = s.budgetExceeded;
  return j;
}

/// The frames to draw: one for --camera; one a row for --path, then numbered frames beside a
/// video at the path's frame rate.
struct RenderPlan final {
  std::vector<FrameJob> jobs;
  double fps = 30.0;
  fs::path prefix;  ///< OUT without its extension: the numbered frames' and the video's name
};

Viewport viewportOf(const RenderCliOptions& c) {
  Viewport viewport;
  viewport.width = c.width;
  viewport.height = c.height;
  viewport.fovYDegrees = c.fovDegrees;
  return viewport;
}

/// Checks every option that needs no dataset (nothing is opened before the command line is
/// known to be good) and fills the frame settings and the cut selection; kExitOk or the exit
/// status of the first bad option.
int checkRenderOptions(const RenderCliOptions& c, const Viewport& viewport,
                       gpu::FrameSettings& settings, RenderModes& modes) {
  if (c.camera.empty() == c.path.empty()) {
    return badInput("give exactly one of --camera LAT,LON,ALT[,HEADING,PITCH,ROLL] or --path FILE");
  }
  if (c.out.empty()) return badInput("--out is required");
  if (auto r = validateViewport(viewport); !r) return reportError(r.error());
  if (!std::isfinite(c.tolerancePixels) || c.tolerancePixels <= 0.0) {
    return badInput("--tolerance-px must be a positive number of pixels");
  }
  if (auto r = checkExaggeration(c.exaggeration); !r) return reportError(r.error());
  if (c.framesInFlight < 1 || c.framesInFlight > gpu::TerrainRenderer::kMaxFramesInFlight) {
    return badInput("--frames-in-flight must be in 1.." +
                    std::to_string(gpu::TerrainRenderer::kMaxFramesInFlight));
  }
  auto selection = parseCutSelection(c.selection);
  if (!selection) return badInput(selection.error().message);
  modes.selection = *selection;
  auto light = parseLight(c.light);
  if (!light) return reportError(light.error());
  modes.light = *light;
  if (!std::isfinite(c.gpuCacheMiB) || c.gpuCacheMiB <= 0.0 || c.gpuCacheMiB > 1048576.0) {
    return badInput("--gpu-cache-mib (--gpu-cache-mb) must be a positive number of MiB");
  }
  std::vector<double> rgb;
  if (!parseNumberList(c.clear, 3, rgb) || std::any_of(rgb.begin(), rgb.end(), [](double v) {
        return v < 0.0 || v > 255.0 || v != std::floor(v);
      })) {
    return badInput("--clear '" + c.clear + "': expected R,G,B integers in 0..255");
  }
  for (std::size_t i = 0; i < 3; ++i) settings.clearRgb[i] = static_cast<std::uint8_t>(rgb[i]);

  const fs::path out(c.out);
  const bool exr = isExrPath(out);
  const std::string ext = out.extension().string();
  if (!c.camera.empty() && !exr && ext != ".png" && ext != ".PNG") {
    return badInput("--out '" + c.out + "': expected a .png or .exr file name");
  }
  if (auto r = checkOutputDirectory(c.out); !r) return reportError(r.error());
  return kExitOk;
}

/// The frames of --camera or of every row of --path, each pose checked against the planet.
int planFrames(const RenderCliOptions& c, const DatasetView& view, RenderPlan& plan) {
  const fs::path out(c.out);
  const bool exr = isExrPath(out);
  std::string ext = out.extension().string();
  if (!c.camera.empty()) {
    auto pose = parseCameraPose(c.camera);
    if (!pose) return reportError(pose.error());
    if (auto r = validateCameraPose(*pose, view.planet()); !r) return reportError(r.error());
    plan.jobs.push_back({*pose, 0.0, out});
    return kExitOk;
  }
  auto points = readCameraPath(c.path);
  if (!points) return reportError(points.error());
  // Frames OUT_000000.png ...: OUT is a prefix (a .png/.exr/.mp4 extension is dropped).
  plan.prefix = out;
  if (ext == ".png" || ext == ".PNG" || exr || ext == ".mp4") plan.prefix.replace_extension();
  ext = exr ? ".exr" : ".png";
  for (std::size_t i = 0; i < points->size(); ++i) {
    const CameraPathPoint& p = (*points)[i];
    const CameraPose pose{p.latDegrees,     p.lonDegrees,   p.altitudeMeters,
                          p.headingDegrees, p.pitchDegrees, p.rollDegrees};
    if (auto r = validateCameraPose(pose, view.planet()); !r) {
      return badInput(c.path + ": row " + std::to_string(i + 1) + ": " + r.error().message);
    }
    plan.jobs.push_back({pose, p.tSeconds, frameName(plan.prefix, i, ext)});
  }
  if (points->size() > 1) {
    plan.fps = static_cast<double>(points->size() - 1) /
               (points->back().tSeconds - points->front().tSeconds);
  }
  return kExitOk;
}

/// Renders and writes every frame of the plan, with a statistics line each (and a JSON line
/// in `statsFile` when it is open).
/// The terrain's exact-mode frames (gpu::Terrain): the cut selected on the device, or on the host
/// with focus regions closed upward or by the screen error alone, the refinement tree kept from
/// frame to frame (the same cuts, fewer decisions).
int renderFrames(const RenderCliOptions& c, const RenderModes& modes,
                 std::unique_ptr<MappedDataset> dataset, const Viewport& viewport,
                 const gpu::FrameSettings& settings, const RenderPlan& plan,
                 std::ofstream& statsFile) {
  const DatasetView& view = dataset->view();
  gpu::ContextOptions contextOptions;
  contextOptions.device = c.device;
  auto context = gpu::VulkanContext::create(contextOptions);
  if (!context) return reportError(context.error());
  gpu::TerrainOptions options;
  options.refinement.tolerancePixels = c.tolerancePixels;
  options.refinement.morphRange = morphRangeOf(c.morph, modes.morph);
  options.refinement.exaggeration = c.exaggeration;
  options.selection = modes.selection;
  auto focus = focusRegions(c.focus, view.planet());
  if (!focus) return reportError(focus.error());
  options.focus = std::move(*focus);
  options.gpuCacheBytes = static_cast<std::uint64_t>(c.gpuCacheMiB * 1048576.0);
  options.viewport = viewport;
  options.framesInFlight = c.framesInFlight;
  options.atmosphere = atmosphereTablesFor(modes.light, view.planet(), c.quiet);
  auto terrain = gpu::Terrain::open(*context, std::move(dataset), std::move(options));
  if (!terrain) return reportError(terrain.error());
  gpu::Terrain& t = **terrain;
  gpu::FrameSettings frameSettings = settings;
  // EXR frames with the atmosphere keep its linear radiance (FrameImage.h).
  frameSettings.readRadiance = isExrPath(plan.jobs.front().out);
  if (!c.viewshed.empty()) {
    auto request = parseViewshedSpec("--viewshed", c.viewshed);
    if (!request) return reportError(request.error());
    auto viewshed = t.viewshed(*request);
    if (!viewshed) return reportError(viewshed.error());
    frameSettings.overlay = viewshedOverlay(*viewshed);
  }
  // One statistics line per frame on a terminal; in logs at most one a second (and the last).
  Progress frameLines(c.quiet, stdout, Progress::OnTerminal::Scroll);
  // Frames in flight: frame i is refined, decoded and recorded while the device draws the
  // frames before it; a frame is collected once framesInFlight are pending, its pixels handed to
  // a writer thread, its statistics written in frame order.
  struct Pending {
    std::size_t index = 0;
    double traversalMs = 0.0;
    CutMorphSummary morph;
  };
  std::deque<Pending> pending;
  FrameWriter writer(std::max(1u, std::thread::hardware_concurrency()));
  const auto collectOne = [&]() -> Result<void> {
    auto frame = t.collect();
    if (!frame) return frame.error();
    const Pending p = pending.front();
    pending.pop_front();
    const FrameJob& job = plan.jobs[p.index];
    if (auto r = writer.write(job.out, std::move(frame->image), std::move(frame->radiance),
                              frameSettings.atmosphereExposure);
        !r) {
      return r;
    }
    const gpu::FrameStats& s = frame->stats;
    if (statsFile.is_open()) {
      statsFile << statsJson(p.index, p.traversalMs, s, p.morph).dump() << "\n";
      statsFile.flush();
      if (!statsFile) return makeError(ErrorCode::IoError, c.stats + ": write failed");
    }
    char line[4608];  // room for a PATH_MAX output name
    std::snprintf(line, sizeof line,
                  "%s%s: %llu patches, %llu triangles, %llu tiles; traversal %.1f ms, decode %.1f "
                  "ms, upload %.1f ms, draw %.1f ms, frame %.1f ms%s",
                  plan.jobs.size() > 1 ? ("frame " + std::to_string(p.index + 1) + "/" +
                                          std::to_string(plan.jobs.size()) + " ")
                                             .c_str()
                                       : "wrote ",
                  job.out.string().c_str(), static_cast<unsigned long long>(s.patches),
                  static_cast<unsigned long long>(s.triangles),
                  static_cast<unsigned long long>(s.tiles), p.traversalMs, s.decodeMs, s.uploadMs,
                  s.drawMs, s.frameMs, s.budgetExceeded ? " (over the GPU cache budget)" : "");
    frameLines.status(line, p.index + 1 == plan.jobs.size());
    return {};
  };
  // A sun placed by azimuth and elevation stands over the first frame's target for the whole path.
  const Camera first = Camera::fromPose(view.planet(), plan.jobs.front().pose, viewport);
  if (const std::string sun = describeLight(modes.light, view.planet(), first, 0.0);
      !sun.empty() && !c.quiet) {
    std::printf("%s\n", sun.c_str());
  }
  for (std::size_t i = 0; i < plan.jobs.size(); ++i) {
    const FrameJob& job = plan.jobs[i];
    const Camera camera = Camera::fromPose(view.planet(), job.pose, viewport);
    auto updated = t.update(camera);
    if (!updated) return reportError(updated.error());
    applyLight(modes.light, view.planet(), first, job.tSeconds, frameSettings);
    if (auto r = t.submit(frameSettings); !r) return reportError(r.error());
    pending.push_back({i, (*updated)->traversalMs, (*updated)->morph});
    while (pending.size() >= t.renderer().framesInFlight() ||
           (i + 1 == plan.jobs.size() && !pending.empty())) {
      if (auto r = collectOne(); !r) return reportError(r.error());
    }
  }
  if (auto r = writer.finish(); !r) return reportError(r.error());
  frameLines.finish();
  return kExitOk;
}

/// Encodes a camera path's numbered PNG frames into PREFIX.mp4 with ffmpeg, when it is on PATH.
int encodeVideo(const RenderPlan& plan, bool quiet) {
  const fs::path video = plan.prefix.string() + ".mp4";
  if (!findOnPath("ffmpeg")) {
    std::printf("ffmpeg not found on PATH: MP4 skipped (frames are %s_NNNNNN.png)\n",
                plan.prefix.string().c_str());
    return kExitOk;
  }
  char rate[32];
  std::snprintf(rate, sizeof rate, "%.6g", plan.fps);
  const int status =
      runProgram({"ffmpeg", "-y", "-loglevel", "error", "-framerate", rate, "-i",
                  plan.prefix.string() + "_%06d.png", "-vf", "pad=ceil(iw/2)*2:ceil(ih/2)*2",
                  "-pix_fmt", "yuv420p", video.string()});
  if (status != 0) {
    return reportError(makeError(ErrorCode::IoError, "ffmpeg failed to make " + video.string() +
                                                         " (exit status " + std::to_string(status) +
                                                         ")"));
  }
  if (!quiet) std::printf("wrote %s (%s fps)\n", video.string().c_str(), rate);
  return kExitOk;
}

int runRender(const RenderCliOptions& c) {
  const Viewport viewport = viewportOf(c);
  gpu::FrameSettings settings;
  RenderModes modes;
  if (const int status = checkRenderOptions(c, viewport, settings, modes); status != kExitOk) {
    return status;
  }

  auto dataset = MappedDataset::open(c.dir, faceOptionsFor(cgroupMemoryLimit()));
  if (!dataset) return reportError(dataset.error());
  const DatasetView& view = (*dataset)->view();
  if (auto r = checkMorphOptions(c.morph, view, false); !r) return reportError(r.error());
  modes.morph = parseOnOff("--morph", c.morph.morph).value();  // checked just above
  if (auto r = checkLightFor(modes.light, view.planet()); !r) return reportError(r.error());
  RenderPlan plan;
  if (const int status = planFrames(c, view, plan); status != kExitOk) return status;

  std::ofstream statsFile;
  if (!c.stats.empty()) {
    statsFile.open(c.stats, std::ios::trunc);
    if (!statsFile) return badInput("--stats '" + c.stats + "': cannot create the file");
  }
  if (const int status =
          renderFrames(c, modes, std::move(*dataset), viewport, settings, plan, statsFile);
      status != kExitOk) {
    return status;
  }

  if (!c.path.empty() && !isExrPath(fs::path(c.out))) return encodeVideo(plan, c.quiet);
  return kExitOk;
}

}  // namespace

void addRenderCommand(CLI::App& app, CommandStatus& status) {
  auto o = std::make_shared<RenderCliOptions>();
  CLI::App* render = app.add_subcommand(
      "render",
      "Render exact-mode frames of a dataset (every patch of the cut) to PNG/EXR, from one "
      "camera or a camera path (then numbered frames OUT_000000.png... and OUT.mp4 if ffmpeg "
      "is installed)");
  render->add_option("DIR", o->dir, "Dataset directory (pbdam build --out)")->required();
  render->add_option("--camera", o->camera,
                     "LAT,LON,ALT[,HEADING,PITCH,ROLL]: degrees, metres above the reference "
                     "surface; pitch -90 (default) looks straight down");
  render->add_option("--path", o->path,
                     "Camera-path CSV (header t,lat,lon,alt,heading,pitch,roll): one frame per "
                     "row, the MP4's frame rate from the t column");
  render
      ->add_option("--out", o->out,
                   "Image file (.png or .exr) with --camera; with --path a prefix OUT: frames "
                   "OUT_000000.png, OUT_000001.png, ... (a .png/.exr/.mp4 extension is "
                   "dropped; .exr gives EXR frames) and OUT.mp4")
      ->required();
  render->add_option("--width", o->width, "Image width in pixels")->capture_default_str();
  render->add_option("--height", o->height, "Image height in pixels")->capture_default_str();
  render->add_option("--fov-deg", o->fovDegrees, "Vertical field of view in degrees")
      ->capture_default_str();
  render
      ->add_option("--tolerance-px", o->tolerancePixels,
                   "Screen-space error tolerance of the cut in pixels")
      ->capture_default_str();
  render
      ->add_option("--gpu-cache-mib,--gpu-cache-mb", o->gpuCacheMiB,
                   "GPU cache budget in MiB (patch and tile slots); a cut that does not fit "
                   "is drawn in several passes. --gpu-cache-mb is its former spelling (also MiB)")
      ->capture_default_str();
  render->add_option("--device", o->device, kDeviceOptionHelp);
  render->add_option("--stats", o->stats,
                     "Write one JSON line of statistics per frame to this file");
  render->add_option("--clear", o->clear, "Background colour R,G,B (0..255)")
      ->capture_default_str();
  addMorphOptions(*render, o->morph, false);
  addExaggerationOption(*render, o->exaggeration);
  addFocusOptions(*render, o->focus);
  render->add_option("--viewshed", o->viewshed,
                     "LAT,LON,HEIGHT_ABOVE_GROUND_M[,RADIUS_M]: drape this eye's viewshed over the "
                     "terrain (visible green, hidden dark; pbdam query viewshed)");
  render
      ->add_option("--selection", o->selection,
                   "cpu: the cut selected on the host; gpu: by the selection's compute passes on "
                   "the device (the same cut on lavapipe)")
      ->capture_default_str();
  render
      ->add_option(
          "--frames-in-flight", o->framesInFlight,
          std::string(kFramesInFlightHelp) + "; frames are encoded and written on worker threads")
      ->capture_default_str();
  addLightOptions(*render, o->light, true);
  render->add_flag("--quiet", o->quiet, "No per-frame lines on stdout");
  render->callback([o, &status] { status.exitCode = runRender(*o); });
}

}  // namespace pbdam::tools
