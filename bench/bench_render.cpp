// Frame cost of exact-mode rendering ([P-BDAM 2003] §6.1, which reports 22% of frame time
// outside the draw): for the four golden views (tests/gpu/TestGoldenFrames.cpp) it times, once
// everything is resident, a full frame — refine() + TerrainRenderer::render() — against a raw
// draw of the same triangles from the same static buffers (TerrainRenderer::redrawLast()), the
// two alternating round by round so that they share the machine's noise. Goal: overhead ≤ 10%.
//
//   pbdam_bench_render MOLA_DIR EARTH_DIR [--frames N] [--width W --height H] [--json FILE]
//
// Runs on lavapipe without validation; LP_NUM_THREADS is taken from the environment.
#include <algorithm>
#include <chrono>
#include <cstdarg>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <filesystem>
#include <fstream>
#include <memory>
#include <string>
#include <string_view>
#include <thread>
#include <vector>

#include "pbdam/gpu/TerrainRenderer.h"
#include "pbdam/gpu/VulkanContext.h"
#include "pbdam/runtime/Refinement.h"
#include "pbdam/streaming/MappedDataset.h"

using namespace pbdam::runtime;
using namespace pbdam::streaming;

namespace {

using pbdam::gpu::RenderedFrame;
using pbdam::gpu::TerrainRenderer;
using pbdam::gpu::TerrainRendererOptions;
using pbdam::gpu::VulkanContext;
using pbdam::runtime::Camera;
using pbdam::runtime::CameraPose;
using pbdam::runtime::Cut;
using pbdam::runtime::RefinementOptions;
using pbdam::streaming::MappedDataset;
using Clock = std::chrono::steady_clock;

double millisecondsBetween(Clock::time_point start, Clock::time_point end) {
  return std::chrono::duration<double, std::milli>(end - start).count();
}

/// The golden views and their poses (kept equal to TestGoldenFrames.cpp).
struct View {
  const char* name;
  int dataset;  ///< 0: MOLA_DIR, 1: EARTH_DIR
  CameraPose pose;
};
constexpr View kViews[] = {
    {"mars_whole", 0, {0.0, -75.0, 5500e3, 0.0, -90.0, 0.0}},
    {"valles_marineris", 0, {-15.0, -68.0, 90e3, 15.0, -30.0, 0.0}},
    {"olympus_mons", 0, {12.5, -133.9, 40e3, 0.0, -14.0, 0.0}},
    {"earth_himalayas", 1, {22.0, 84.0, 700e3, 10.0, -35.0, 0.0}},
};

struct Options {
  std::filesystem::path datasets[2];
  int frames = 20;
  std::uint32_t width = 1280;
  std::uint32_t height = 720;
  std::string json;
};

/// One round: a full frame and a raw redraw.
struct Round {
  double fullMs = 0.0;       ///< refine() + render(), wall
  double rawMs = 0.0;        ///< redrawLast(), wall
  double traversalMs = 0.0;  ///< refine()
  double decodeMs = 0.0;
  double uploadMs = 0.0;
  double drawMs = 0.0;     ///< render()'s render pass (timestamps)
  double otherMs = 0.0;    ///< the rest of the full frame: records, recording, readback, …
  double rawDrawMs = 0.0;  ///< redrawLast()'s render pass (timestamps)
  double overhead = 0.0;   ///< (full − raw) / full
  /// (full − its draw) − (raw − its draw): the full frame's extra time outside the render pass,
  /// without the draws' own noise.
  double outsideDrawMs = 0.0;
};

struct ViewResult {
  const View* view = nullptr;
  std::uint64_t patches = 0, triangles = 0, tiles = 0;
  double firstMs = 0.0;  ///< the cold first frame: refine() + render(), everything uploaded
  double firstDecodeMs = 0.0, firstUploadMs = 0.0;
  std::uint64_t firstMisses = 0, firstBytesUploaded = 0;
  std::uint64_t roundMisses = 0;  ///< misses during the rounds (0 once resident)
  bool identical = true;          ///< every redraw's image equals the full frame's
  std::vector<Round> rounds;
};

double median(std::vector<double> values) {
  if (values.empty()) return 0.0;
  std::sort(values.begin(), values.end());
  const std::size_t n = values.size();
  return n % 2 == 1 ? values[n / 2] : 0.5 * (values[n / 2 - 1] + values[n / 2]);
}

template <typename Field>
double medianOf(const std::vector<Round>& rounds, Field field) {
  std::vector<double> values;
  values.reserve(rounds.size());
  for (const Round& r : rounds) values.push_back(r.*field);
  return median(std::move(values));
}

int usage(const char* message) {
  std::fprintf(stderr,
               "%s\nusage: pbdam_bench_render MOLA_DIR EARTH_DIR [--frames N=20] "
               "[--width W=1280 --height H=720] [--json FILE]\n",
               message);
  return 2;
}

bool parseUnsigned(std::string_view text, std::uint32_t minimum, std::uint32_t maximum,
                   std::uint32_t& out) {
  if (text.empty() || text.size() > 9) return false;
  std::uint32_t value = 0;
  for (const char c : text) {
    if (c < '0' || c > '9') return false;
    value = 10 * value + static_cast<std::uint32_t>(c - '0');
  }
  if (value < minimum || value > maximum) return false;
  out = value;
  return true;
}

/// Renders one view: the cold frame, then `frames` alternating rounds.
pbdam::formats::Result<ViewResult> benchView(VulkanContext& context, const MappedDataset& dataset,
                                             const View& view, const Options& options) {
  const pbdam::runtime::DatasetView& data = dataset.view();
  TerrainRendererOptions rendererOptions;
  rendererOptions.widthPixels = options.width;
  rendererOptions.heightPixels = options.height;
  auto renderer = TerrainRenderer::create(context, data, rendererOptions);
  if (!renderer) return std::move(renderer).error();
  pbdam::runtime::Viewport viewport;
  viewport.width = options.width;
  viewport.height = options.height;
  const Camera camera = Camera::fromPose(data.planet(), view.pose, viewport);
  const RefinementOptions refinement;

  ViewResult result;
  result.view = &view;
  {
    const auto start = Clock::now();
    const Cut cut = pbdam::runtime::refine(data, camera, refinement);
    auto frame = renderer->render(cut, camera);
    const auto end = Clock::now();
    if (!frame) return std::move(frame).error();
    if (frame->stats.passes != 1) {
      return pbdam::formats::makeError(pbdam::formats::ErrorCode::InvalidArgument,
                                       std::string(view.name) +
                                           ": the cut does not fit the GPU cache " + "budget (" +
                                           std::to_string(frame->stats.passes) +
                                           " passes); there is no raw draw to compare with");
    }
    result.firstMs = millisecondsBetween(start, end);
    result.patches = frame->stats.patches;
    result.triangles = frame->stats.triangles;
    result.tiles = frame->stats.tiles;
    result.firstDecodeMs = frame->stats.decodeMs;
    result.firstUploadMs = frame->stats.uploadMs;
    result.firstMisses = frame->stats.misses;
    result.firstBytesUploaded = frame->stats.bytesUploaded;
  }

  for (int round = 0; round < options.frames; ++round) {
    Round r;
    RenderedFrame full, raw;
    // Alternate which goes first, so that neither always follows the other.
    for (int step = 0; step < 2; ++step) {
      if ((step == 0) == (round % 2 == 0)) {
        const auto start = Clock::now();
        const Cut cut = pbdam::runtime::refine(data, camera, refinement);
        const auto refined = Clock::now();
        auto frame = renderer->render(cut, camera);
        const auto end = Clock::now();
        if (!frame) return std::move(frame).error();
        r.fullMs = millisecondsBetween(start, end);
        r.traversalMs = millisecondsBetween(start, refined);
        r.decodeMs = frame->stats.decodeMs;
        r.uploadMs = frame->stats.uploadMs;
        r.drawMs = frame->stats.drawMs;
        result.roundMisses += frame->stats.misses;
        full = std::move(*frame);
      } else {
        const auto start = Clock::now();
        auto frame = renderer->redrawLast();
        const auto end = Clock::now();
        if (!frame) return std::move(frame).error();
        r.rawMs = millisecondsBetween(start, end);
        r.rawDrawMs = frame->stats.drawMs;
        raw = std::move(*frame);
      }
    }
    r.otherMs = r.fullMs - r.traversalMs - r.decodeMs - r.uploadMs - r.drawMs;
    r.overhead = (r.fullMs - r.rawMs) / r.fullMs;
    r.outsideDrawMs = (r.fullMs - r.drawMs) - (r.rawMs - r.rawDrawMs);
    if (full.image.rgba != raw.image.rgba) result.identical = false;
    result.rounds.push_back(r);
  }
  return result;
}

double trianglesPerSecond(std::uint64_t triangles, double milliseconds) {
  return milliseconds > 0.0 ? static_cast<double>(triangles) / (milliseconds * 1e-3) : 0.0;
}

void printTables(const std::vector<ViewResult>& results) {
  std::printf("\n%-17s %7s %9s %9s %8s %8s %11s %11s %9s %9s\n", "view", "patches", "triangles",
              "first ms", "full ms", "raw ms", "Mtri/s full", "Mtri/s raw", "overhead",
              "med ratio");
  for (const ViewResult& v : results) {
    const double full = medianOf(v.rounds, &Round::fullMs);
    const double raw = medianOf(v.rounds, &Round::rawMs);
    std::printf("%-17s %7llu %9llu %9.1f %8.2f %8.2f %11.2f %11.2f %8.1f%% %8.1f%%\n", v.view->name,
                static_cast<unsigned long long>(v.patches),
                static_cast<unsigned long long>(v.triangles), v.firstMs, full, raw,
                trianglesPerSecond(v.triangles, full) * 1e-6,
                trianglesPerSecond(v.triangles, raw) * 1e-6, 100.0 * (full - raw) / full,
                100.0 * medianOf(v.rounds, &Round::overhead));
  }
  std::printf(
      "\nfull frame split (medians, ms)                           | raw (medians, ms)       |"
      " extra outside draw\n");
  std::printf("%-17s %9s %8s %8s %8s %12s | %8s %14s | %8s %8s %7s %9s\n", "view", "traversal",
              "decode", "upload", "draw", "record/other", "draw", "readback/other", "ms", "share",
              "misses", "identical");
  for (const ViewResult& v : results) {
    std::vector<double> rawOther;
    for (const Round& r : v.rounds) rawOther.push_back(r.rawMs - r.rawDrawMs);
    const double outside = medianOf(v.rounds, &Round::outsideDrawMs);
    std::printf("%-17s %9.2f %8.2f %8.2f %8.2f %12.2f | %8.2f %14.2f | %8.2f %7.1f%% %7llu %9s\n",
                v.view->name, medianOf(v.rounds, &Round::traversalMs),
                medianOf(v.rounds, &Round::decodeMs), medianOf(v.rounds, &Round::uploadMs),
                medianOf(v.rounds, &Round::drawMs), medianOf(v.rounds, &Round::otherMs),
                medianOf(v.rounds, &Round::rawDrawMs), median(std::move(rawOther)), outside,
                100.0 * outside / medianOf(v.rounds, &Round::fullMs),
                static_cast<unsigned long long>(v.roundMisses), v.identical ? "yes" : "NO");
  }
  std::printf(
      "(record/other: per-draw records, command recording, submission, readback; extra outside "
      "draw: median of (full - its draw) - (raw - its draw), draw times from timestamps)\n");
  std::printf("\nfirst frame (cold): every patch and tile decoded and uploaded\n");
  std::printf("%-17s %9s %8s %8s %8s %10s\n", "view", "first ms", "decode", "upload", "misses",
              "MiB up");
  for (const ViewResult& v : results) {
    std::printf("%-17s %9.1f %8.2f %8.2f %8llu %10.2f\n", v.view->name, v.firstMs, v.firstDecodeMs,
                v.firstUploadMs, static_cast<unsigned long long>(v.firstMisses),
                static_cast<double>(v.firstBytesUploaded) / (1024.0 * 1024.0));
  }
}

// printf into a string (the JSON report is written in one piece).
[[gnu::format(printf, 2, 3)]] void appendf(std::string& out, const char* format, ...) {
  va_list args;
  va_start(args, format);
  va_list again;
  va_copy(again, args);
  const int n = std::vsnprintf(nullptr, 0, format, args);
  va_end(args);
  if (n > 0) {
    const std::size_t size = out.size();
    out.resize(size + static_cast<std::size_t>(n) + 1);
    std::vsnprintf(out.data() + size, static_cast<std::size_t>(n) + 1, format, again);
    out.resize(size + static_cast<std::size_t>(n));
  }
  va_end(again);
}

void writeSeries(std::string& out, const char* name, const std::vector<Round>& rounds,
                 double Round::*field) {
  appendf(out, "\"%s\": [", name);
  for (std::size_t i = 0; i < rounds.size(); ++i) {
    appendf(out, "%s%.4f", i == 0 ? "" : ", ", rounds[i].*field);
  }
  appendf(out, "]");
}

bool writeJson(const std::string& path, const VulkanContext& context, const char* lpThreads,
               const Options& options, const std::vector<ViewResult>& results) {
  std::string out;
  appendf(out,
          "{\n  \"device\": \"%s\",\n  \"driver\": \"%s\",\n  \"lpNumThreads\": \"%s\",\n"
          "  \"hardwareThreads\": %u,\n  \"width\": %u,\n  \"height\": %u,\n"
          "  \"frames\": %d,\n  \"views\": [\n",
          context.deviceInfo().name.c_str(), context.deviceInfo().driverInfo.c_str(), lpThreads,
          std::thread::hardware_concurrency(), options.width, options.height, options.frames);
  for (std::size_t i = 0; i < results.size(); ++i) {
    const ViewResult& v = results[i];
    const double full = medianOf(v.rounds, &Round::fullMs);
    const double raw = medianOf(v.rounds, &Round::rawMs);
    appendf(out,
            "    {\"name\": \"%s\", \"patches\": %llu, \"triangles\": %llu, \"tiles\": %llu,\n"
            "     \"firstMs\": %.4f, \"fullMs\": %.4f, \"rawMs\": %.4f,\n"
            "     \"trianglesPerSecondFull\": %.1f, \"trianglesPerSecondRaw\": %.1f,\n"
            "     \"overheadShare\": %.5f, \"medianRoundOverheadShare\": %.5f,\n"
            "     \"traversalMs\": %.4f, \"decodeMs\": %.4f, \"uploadMs\": %.4f, "
            "\"drawMs\": %.4f, \"otherMs\": %.4f, \"rawDrawMs\": %.4f, \"outsideDrawMs\": %.4f,\n"
            "     \"roundMisses\": %llu, \"identicalImages\": %s,\n     ",
            v.view->name, static_cast<unsigned long long>(v.patches),
            static_cast<unsigned long long>(v.triangles), static_cast<unsigned long long>(v.tiles),
            v.firstMs, full, raw, trianglesPerSecond(v.triangles, full),
            trianglesPerSecond(v.triangles, raw), (full - raw) / full,
            medianOf(v.rounds, &Round::overhead), medianOf(v.rounds, &Round::traversalMs),
            medianOf(v.rounds, &Round::decodeMs), medianOf(v.rounds, &Round::uploadMs),
            medianOf(v.rounds, &Round::drawMs), medianOf(v.rounds, &Round::otherMs),
            medianOf(v.rounds, &Round::rawDrawMs), medianOf(v.rounds, &Round::outsideDrawMs),
            static_cast<unsigned long long>(v.roundMisses), v.identical ? "true" : "false");
    writeSeries(out, "roundFullMs", v.rounds, &Round::fullMs);
    appendf(out, ",\n     ");
    writeSeries(out, "roundRawMs", v.rounds, &Round::rawMs);
    appendf(out, "}%s\n", i + 1 == results.size() ? "" : ",");
  }
  appendf(out, "  ]\n}\n");
  std::ofstream file(path, std::ios::binary | std::ios::trunc);
  file << out;
  file.close();
  return file.good();
}

int run(int argc, char** argv) {
  Options options;
  int positional = 0;
  for (int i = 1; i < argc; ++i) {
    const std::string_view arg = argv[i];
    const bool hasValue = i + 1 < argc;
    if (arg == "--frames" && hasValue) {
      std::uint32_t frames = 0;
      if (!parseUnsigned(argv[++i], 1, 100000, frames)) return usage("--frames: 1..100000");
      options.frames = static_cast<int>(frames);
    } else if (arg == "--width" && hasValue) {
      if (!parseUnsigned(argv[++i], 1, 16384, options.width)) return usage("--width: 1..16384");
    } else if (arg == "--height" && hasValue) {
      if (!parseUnsigned(argv[++i], 1, 16384, options.height)) return usage("--height: 1..16384");
    } else if (arg == "--json" && hasValue) {
      options.json = argv[++i];
    } else if (!arg.starts_with("--") && positional < 2) {
      options.datasets[positional++] = argv[i];
    } else {
      return usage(("unexpected argument: " + std::string(arg)).c_str());
    }
  }
  if (positional != 2) return usage("two dataset directories are needed");

  std::unique_ptr<MappedDataset> datasets[2];
  for (int d = 0; d < 2; ++d) {
    auto opened = MappedDataset::open(options.datasets[d]);
    if (!opened) {
      std::fprintf(stderr, "pbdam_bench_render: %s\n", opened.error().message.c_str());
      return 1;
    }
    datasets[d] = std::move(*opened);
  }
  pbdam::gpu::ContextOptions contextOptions;
  contextOptions.enableValidation = false;  // performance
  contextOptions.applicationName = "pbdam_bench_render";
  auto context = VulkanContext::create(contextOptions);
  if (!context) {
    std::fprintf(stderr, "pbdam_bench_render: %s\n", context.error().message.c_str());
    return 1;
  }
  const char* lpThreadsEnv = std::getenv("LP_NUM_THREADS");
  const char* lpThreads = lpThreadsEnv != nullptr ? lpThreadsEnv : "unset";
  std::printf("device: %s (%s), validation off\n", context->deviceInfo().name.c_str(),
              context->deviceInfo().driverInfo.c_str());
  std::printf("LP_NUM_THREADS=%s (hardware threads: %u)\n", lpThreads,
              std::thread::hardware_concurrency());
  std::printf(
      "%ux%u, GPU cache budget %llu MiB, %d rounds per view (full frame and raw draw "
      "alternating; first frame excluded)\n",
      options.width, options.height,
      static_cast<unsigned long long>(TerrainRendererOptions{}.gpuCacheBytes >> 20),
      options.frames);
  std::printf(
      "full = refine() + render(); raw = redrawLast() (the same draw from resident "
      "buffers); overhead = (full - raw) / full of the medians; goal <= 10%% "
      "(paper: 22%%)\n");

  std::vector<ViewResult> results;
  for (const View& view : kViews) {
    auto result =
        benchView(*context, *datasets[static_cast<std::size_t>(view.dataset)], view, options);
    if (!result) {
      std::fprintf(stderr, "pbdam_bench_render: %s: %s\n", view.name,
                   result.error().message.c_str());
      return 1;
    }
    results.push_back(std::move(*result));
  }
  printTables(results);
  if (!options.json.empty() && !writeJson(options.json, *context, lpThreads, options, results)) {
    std::fprintf(stderr, "pbdam_bench_render: cannot write %s\n", options.json.c_str());
    return 1;
  }
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  try {
    return run(argc, argv);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "pbdam_bench_render: %s\n", e.what());
  } catch (...) {
    std::fprintf(stderr, "pbdam_bench_render: unknown exception\n");
  }
  return 1;
}
