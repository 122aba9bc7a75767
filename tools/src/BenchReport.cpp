// frames.csv, summary.json and report.png of `pbdam bench` (BenchReport.h).
#include "BenchReport.h"

#include <plplot/plplot.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <nlohmann/json.hpp>
#include <numeric>
#include <sstream>

using namespace pbdam::formats;
using namespace pbdam::gpu;

namespace pbdam::tools {

double percentile(std::vector<double> v, double p) {
  if (v.empty()) return 0.0;
  std::sort(v.begin(), v.end());
  const double rank = p * static_cast<double>(v.size() - 1);
  const auto lo = static_cast<std::size_t>(std::floor(rank));
  const auto hi = std::min(lo + 1, v.size() - 1);
  return v[lo] + (rank - static_cast<double>(lo)) * (v[hi] - v[lo]);
}

namespace {

/// The share of the run's wall time the device was busy with its frames: their upload and draw
/// times (timestamp queries; on lavapipe the CPU time the driver spent on them) over
/// BenchRun::wallMs. The device works inside a frame's wall time and one submission at a time,
/// so it is at most 1 up to the timestamps' resolution; 0 for a run without frames.
double gpuBusyFraction(const BenchRun& run) {
  double gpuMs = 0.0;
  for (const BenchFrame& f : run.frames) gpuMs += f.uploadMs + f.drawMs;
  return run.wallMs > 0.0 ? gpuMs / run.wallMs : 0.0;
}

// --popping: the per-frame differences' percentiles (frames without one are skipped).
void addPopping(const BenchRun& run, nlohmann::ordered_json& j) {
  std::vector<double> rms, max;
  for (const BenchFrame& f : run.frames) {
    if (f.poppingRms < 0.0) continue;
    rms.push_back(f.poppingRms);
    max.push_back(f.poppingMax);
  }
  j["popping_rms_p50"] = percentile(rms, 0.5);
  j["popping_rms_p99"] = percentile(rms, 0.99);
  j["popping_rms_max"] = rms.empty() ? 0.0 : *std::max_element(rms.begin(), rms.end());
  j["popping_max_p50"] = percentile(max, 0.5);
  j["popping_max_p99"] = percentile(max, 0.99);
  j["popping_max_max"] = max.empty() ? 0.0 : *std::max_element(max.begin(), max.end());
}

nlohmann::ordered_json summarise(const BenchRun& run, const BenchSetup& setup) {
  std::vector<double> ms, drawMs;
  double total = 0.0, traversal = 0.0, peakTps = 0.0, triangles = 0.0, draws = 0.0, decisions = 0.0;
  std::uint64_t faults = 0, maxPatches = 0, maxTiles = 0, peakRss = 0, hits = 0, misses = 0,
                paged = 0, peakDatasetRss = 0, peakPool = 0;
  for (const BenchFrame& f : run.frames) {
    ms.push_back(f.frameMs);
    drawMs.push_back(f.drawMs);
    total += f.frameMs;
    traversal += f.traversalMs;
    triangles += static_cast<double>(f.triangles);
    draws += static_cast<double>(f.patches);  // one indexed draw per patch
    decisions += static_cast<double>(f.decisions);
    if (f.frameMs > 0.0)
      peakTps = std::max(peakTps, static_cast<double>(f.triangles) / f.frameMs * 1e3);
    faults += f.renderThreadMajorFaults;
    maxPatches = std::max(maxPatches, f.patches);
    maxTiles = std::max(maxTiles, f.tiles);
    peakRss = std::max(peakRss, f.rssBytes);
    // Dataset pages in the process: file-backed RSS above the libraries' share.
    if (f.rssFileBytes > run.baselineRssFileBytes) {
      peakDatasetRss = std::max(peakDatasetRss, f.rssFileBytes - run.baselineRssFileBytes);
    }
    peakPool = std::max(peakPool, f.gpuPoolBytes);
    hits += f.gpuHits;
    misses += f.gpuMisses;
    paged += f.bytesPagedIn;
  }
  const double median = percentile(ms, 0.5);
  const auto stalls =
      std::count_if(ms.begin(), ms.end(), [&](double m) { return m > 2.0 * median; });
  // Stalls the draw does not explain: the frame's time outside the draw (traversal, faults,
  // decode, upload, readback) alone exceeds a median frame. On lavapipe the draw of a frame
  // varies 2x with its triangle count, so the plain count above also counts busy views.
  const auto dataStalls = std::count_if(run.frames.begin(), run.frames.end(), [&](const auto& f) {
    return f.frameMs - f.drawMs > median;
  });
  const double datasetMb = static_cast<double>(setup.datasetBytes) / 1048576.0;
  const double rssMb = static_cast<double>(peakRss) / 1048576.0;
  nlohmann::ordered_json j;
  j["prefetch"] = onOff(run.prefetch);
  j["morph"] = onOff(run.morph);
  j["mode"] = toString(run.mode);
  j["cut_reuse"] = run.cutReuse;
  j["selection"] = toString(run.selection);
  if (run.selection == CutSelection::Gpu) {
    j["draws"] = toString(run.draws);
    j["selection_frames_differing"] = run.selectionFramesDiffering;
    j["selection_max_screen_error_ratio"] = run.selectionMaxScreenRatio;
  }
  j["cold"] = run.cold;
  if (run.cold) {
    j["resident_after_evict_pages"] = run.residentAfterEvictPages;
    j["resident_after_evict_fraction"] = run.residentAfterEvictFraction;
  }
  j["frames"] = run.frames.size();
  j["fps_mean"] = total > 0.0 ? 1e3 * static_cast<double>(run.frames.size()) / total : 0.0;
  j["frame_ms_p50"] = median;
  j["frame_ms_p95"] = percentile(ms, 0.95);
  j["frame_ms_p99"] = percentile(ms, 0.99);
  j["frame_ms_max"] = ms.empty() ? 0.0 : *std::max_element(ms.begin(), ms.end());
  j["draw_ms_p50"] = percentile(drawMs, 0.5);
  j["gpu_busy_fraction"] = gpuBusyFraction(run);
  j["frames_in_flight"] = run.framesInFlight;
  j["readback"] = run.readback;
  j["gpu_cache_mib"] = static_cast<double>(run.gpuCacheBytes) / 1048576.0;
  j["memory_budget_mib"] = static_cast<double>(run.memoryBudgetBytes) / 1048576.0;
  j["memory_budget_source"] = run.memoryBudgetSource;
  j["node_tables_paged"] = run.nodeTablesPaged;
  j["node_chunk_reads"] = run.nodeChunkReads;
  j["stalls"] = stalls;
  j["data_stalls"] = dataStalls;
  // No-stall: frames drawn under a level cap above the dataset's depth (data not resident
  // yet), and frames with nothing drawn (not even the roots resident: cap −1).
  const bool noStall = run.mode == StreamingMode::NoStall;
  j["frames_below_full_depth"] = std::count_if(
      run.frames.begin(), run.frames.end(),
      [&](const BenchFrame& f) { return noStall && f.drawnLevelCap < run.datasetDepth; });
  j["frames_empty"] = std::count_if(run.frames.begin(), run.frames.end(), [&](const BenchFrame& f) {
    return noStall && f.drawnLevelCap < 0;
  });
  j["triangles_per_s_mean"] = total > 0.0 ? triangles / total * 1e3 : 0.0;
  j["triangles_per_s_peak"] = peakTps;
  const double frames = std::max<double>(1.0, static_cast<double>(run.frames.size()));
  j["triangles_per_frame_mean"] = triangles / frames;
  j["draws_per_frame_mean"] = draws / frames;
  j["decisions_per_frame_mean"] = decisions / frames;
  double morphing = 0.0;
  for (const BenchFrame& f : run.frames) morphing += static_cast<double>(f.morphingPatches);
  j["morphing_patches_per_frame_mean"] = morphing / frames;
  j["max_patches_per_frame"] = maxPatches;
  j["max_tiles_per_frame"] = maxTiles;
  j["traversal_fraction"] = total > 0.0 ? traversal / total : 0.0;
  j["traversal_ms_mean"] = traversal / frames;
  j["render_thread_major_faults"] = faults;
  // The cold first frame faults in whatever its cut needs before any camera could be
  // predicted, racing the prefetcher for the same pages: its count varies from run to run
  // and can dominate a small total, so the rest is given on its own.
  j["render_thread_major_faults_after_first_frame"] =
      run.frames.empty() ? std::uint64_t{0} : faults - run.frames.front().renderThreadMajorFaults;
  j["bytes_paged_in"] = paged;
  j["prefetch_ranges_advised"] = run.prefetchRangesAdvised;
  j["prefetch_bytes_advised"] = run.prefetchBytesAdvised;
  j["prefetch_ranges_deferred"] = run.prefetchRangesDeferred;
  j["prefetch_ranges_used"] = run.prefetchRangesUsed;
  j["prefetch_ranges_evicted_before_use"] = run.prefetchRangesEvictedBeforeUse;
  j["peak_rss_mib"] = rssMb;
  j["dataset_mib"] = datasetMb;
  j["rss_dataset_ratio"] = datasetMb > 0.0 ? rssMb / datasetMb : 0.0;
  const double datasetRssMb = static_cast<double>(peakDatasetRss) / 1048576.0;
  j["peak_dataset_rss_mib"] = datasetRssMb;
  j["dataset_rss_ratio"] = datasetMb > 0.0 ? datasetRssMb / datasetMb : 0.0;
  j["peak_gpu_pool_mib"] = static_cast<double>(peakPool) / 1048576.0;
  if (run.popping) addPopping(run, j);
  j["gpu_cache_hit_rate"] =
      hits + misses > 0 ? static_cast<double>(hits) / static_cast<double>(hits + misses) : 0.0;
  return j;
}

// One panel: a series per run against path time.
void panel(const std::vector<BenchRun>& runs, const char* title, const char* ylabel,
           double (*value)(const BenchFrame&)) {
  double xmax = 1e-3, ymax = 1e-9;
  for (const BenchRun& r : runs) {
    for (const BenchFrame& f : r.frames) {
      xmax = std::max(xmax, f.pathSeconds);
      ymax = std::max(ymax, value(f));
    }
  }
  plcol0(15);
  plenv(0.0, xmax, 0.0, ymax * 1.08, 0, 0);
  pllab("path time (s)", ylabel, title);
  static const int colours[] = {1, 9, 3, 8};
  for (std::size_t k = 0; k < runs.size(); ++k) {
    std::vector<PLFLT> x, y;
    for (const BenchFrame& f : runs[k].frames) {
      x.push_back(f.pathSeconds);
      y.push_back(value(f));
    }
    plcol0(colours[k % 4]);
    plwidth(1.5);
    if (!x.empty()) plline(static_cast<PLINT>(x.size()), x.data(), y.data());
  }
  plwidth(1.0);
}

void plotReport(const std::filesystem::path& png, const BenchSetup& setup,
                const std::vector<BenchRun>& runs) {
  plsdev("pngcairo");
  plsfnam(png.string().c_str());
  plspage(0.0, 0.0, 1400, 1400, 0, 0);
  plscolbg(255, 255, 255);
  plscol0(15, 0, 0, 0);
  plscol0(1, 220, 50, 32);    // run 0: red
  plscol0(9, 30, 90, 200);    // run 1: blue
  plscol0(8, 110, 110, 110);  // run 3: grey (PLplot's colour 8 is brown); run 2: its green
  const bool popping =
      std::any_of(runs.begin(), runs.end(), [](const BenchRun& r) { return r.popping; });
  plssub(1, popping ? 5 : 4);
  plinit();
  std::string legend;
  static const char* names[] = {"red", "blue", "green", "grey"};
  for (std::size_t k = 0; k < runs.size(); ++k) {
    legend += std::string(k ? "; " : "") + names[k % 4] + ": morph " + onOff(runs[k].morph) +
              ", prefetch " + onOff(runs[k].prefetch);
  }
  const std::string title = "frame rate (" + legend + ", " + std::to_string(setup.width) + "x" +
                            std::to_string(setup.height) + ")";
  panel(runs, title.c_str(), "frames/s",
        [](const BenchFrame& f) { return f.frameMs > 0.0 ? 1e3 / f.frameMs : 0.0; });
  // Between the title and the panel: each run's share of the wall time the device was busy.
  std::string busy = "GPU busy (upload + draw over the run's wall time):";
  for (std::size_t k = 0; k < runs.size(); ++k) {
    char share[48];
    std::snprintf(share, sizeof share, "%s %s %.1f%%", k ? ";" : "", names[k % 4],
                  100.0 * gpuBusyFraction(runs[k]));
    busy += share;
  }
  // Every run of one bench has the same frames in flight and readback.
  if (!runs.empty()) {
    busy += "  (" + std::to_string(runs.front().framesInFlight) + " in flight, readback " +
            onOff(runs.front().readback) + ")";
  }
  plcol0(15);
  plschr(0.0, 0.85);
  plmtex("t", 0.8, 0.0, 0.0, busy.c_str());
  plschr(0.0, 1.0);
  panel(runs, "triangles per frame", "triangles",
        [](const BenchFrame& f) { return static_cast<double>(f.triangles); });
  panel(runs, "patches per frame", "patches",
        [](const BenchFrame& f) { return static_cast<double>(f.patches); });
  panel(runs, "render-thread major page faults per frame", "faults",
        [](const BenchFrame& f) { return static_cast<double>(f.renderThreadMajorFaults); });
  if (popping) {
    panel(runs, "popping: RMS difference from the previous frame's cut (0-255)", "RMS",
          [](const BenchFrame& f) { return std::max(0.0, f.poppingRms); });
  }
  plend();
}

/// summary.json's description of the benchmark: dataset, path, frame size, refinement, cache,
/// exaggeration and light.
nlohmann::ordered_json setupJson(const BenchSetup& setup) {
  nlohmann::ordered_json summary;
  summary["dataset"] = setup.dataset;
  summary["path"] = setup.path;
  summary["width"] = setup.width;
  summary["height"] = setup.height;
  summary["tolerance_px"] = setup.tolerancePixels;
  summary["morph_range"] = setup.morphRange;
  summary["lookahead_s"] = setup.lookaheadSeconds;
  summary["gpu_cache_mib"] = static_cast<double>(setup.gpuCacheBytes) / 1048576.0;
  summary["dataset_mib"] = static_cast<double>(setup.datasetBytes) / 1048576.0;
  summary["exaggeration"] = setup.exaggeration;
  nlohmann::ordered_json light;
  light["kind"] = setup.light.kind;
  if (setup.light.kind == "time") {
    light["time"] = setup.light.time;
    light["time_scale"] = setup.light.timeScale;
  } else if (setup.light.kind == "sun") {
    light["azimuth_deg"] = setup.light.azimuthDegrees;
    light["elevation_deg"] = setup.light.elevationDegrees;
  }
  light["ambient"] = setup.light.ambient;
  light["atmosphere"] = setup.light.exposure > 0.0;
  if (setup.light.exposure > 0.0) light["exposure"] = setup.light.exposure;
  light["normal_maps"] = setup.light.normalMaps;
  summary["light"] = light;
  return summary;
}

}  // namespace

Result<std::string> writeBenchReport(const std::filesystem::path& dir, const BenchSetup& setup,
                                     const std::vector<BenchRun>& runs) {
  std::error_code ec;
  std::filesystem::create_directories(dir, ec);
  if (ec) {
    return makeError(ErrorCode::IoError, dir.string() + ": cannot create (" + ec.message() + ")");
  }
  {
    std::ofstream csv(dir / "frames.csv");
    csv << "prefetch,mode,frame,t,frame_ms,traversal_ms,decode_ms,upload_ms,draw_ms,triangles,"
           "patches,tiles,level_cap,render_thread_major_faults,bytes_paged_in,gpu_hits,"
           "gpu_misses,gpu_evictions,rss_bytes,gpu_pool_bytes,rss_file_bytes,decisions,popping_rms,"
           "popping_max,morph,morphing_patches\n";
    for (const BenchRun& r : runs) {
      for (const BenchFrame& f : r.frames) {
        csv << onOff(r.prefetch) << ',' << toString(r.mode) << ',' << f.frame << ','
            << f.pathSeconds << ',' << f.frameMs << ',' << f.traversalMs << ',' << f.decodeMs << ','
            << f.uploadMs << ',' << f.drawMs << ',' << f.triangles << ',' << f.patches << ','
            << f.tiles << ',' << f.drawnLevelCap << ',' << f.renderThreadMajorFaults << ','
            << f.bytesPagedIn << ',' << f.gpuHits << ',' << f.gpuMisses << ',' << f.gpuEvictions
            << ',' << f.rssBytes << ',' << f.gpuPoolBytes << ',' << f.rssFileBytes << ','
            << f.decisions << ',' << f.poppingRms << ',' << f.poppingMax << ',' << onOff(r.morph)
            << ',' << f.morphingPatches << '\n';
      }
    }
    if (!csv)
      return makeError(ErrorCode::IoError, (dir / "frames.csv").string() + ": write failed");
  }
  nlohmann::ordered_json summary = setupJson(setup);
  summary["runs"] = nlohmann::ordered_json::array();
  for (const BenchRun& r : runs) summary["runs"].push_back(summarise(r, setup));
  {
    std::ofstream out(dir / "summary.json");
    out << summary.dump(2) << "\n";
    if (!out) {
      return makeError(ErrorCode::IoError, (dir / "summary.json").string() + ": write failed");
    }
  }
  plotReport(dir / "report.png", setup, runs);

  std::ostringstream text;
  char line[512];
  for (std::size_t k = 0; k < runs.size(); ++k) {
    const auto& r = summary["runs"][k];
    std::snprintf(
        line, sizeof line,
        "prefetch %-3s %-8s %4zu frames  %.1f fps  frame ms p50 %.1f p95 %.1f p99 %.1f "
        "max %.1f  stalls %lld  major faults %llu  traversal %.1f%%  peak RSS %.0f MiB "
        "(%.1f%% of %.0f MiB)  GPU hit rate %.1f%%\n",
        r["prefetch"].get<std::string>().c_str(), r["mode"].get<std::string>().c_str(),
        r["frames"].get<std::size_t>(), r["fps_mean"].get<double>(),
        r["frame_ms_p50"].get<double>(), r["frame_ms_p95"].get<double>(),
        r["frame_ms_p99"].get<double>(), r["frame_ms_max"].get<double>(),
        static_cast<long long>(r["stalls"].get<std::int64_t>()),
        static_cast<unsigned long long>(r["render_thread_major_faults"].get<std::uint64_t>()),
        100.0 * r["traversal_fraction"].get<double>(), r["peak_rss_mib"].get<double>(),
        100.0 * r["rss_dataset_ratio"].get<double>(), r["dataset_mib"].get<double>(),
        100.0 * r["gpu_cache_hit_rate"].get<double>());
    text << line;
    std::snprintf(line, sizeof line,
                  "  per frame: %.0f triangles in %.0f draws on average (one per patch; at most "
                  "%llu); %.1f split/cull decisions (cut reuse %s); %u in flight, readback "
                  "%s\n",
                  r["triangles_per_frame_mean"].get<double>(),
                  r["draws_per_frame_mean"].get<double>(),
                  static_cast<unsigned long long>(r["max_patches_per_frame"].get<std::uint64_t>()),
                  r["decisions_per_frame_mean"].get<double>(), onOff(runs[k].cutReuse),
                  runs[k].framesInFlight, onOff(runs[k].readback));
    text << line;
    std::snprintf(
        line, sizeof line,
        "  data stalls (time outside the draw > median frame) %lld; dataset pages in "
        "RSS peak %.1f MiB (%.2f%% of the dataset); GPU cache pools %.0f MiB; GPU "
        "busy %.1f%% of the wall time\n",
        static_cast<long long>(r["data_stalls"].get<std::int64_t>()),
        r["peak_dataset_rss_mib"].get<double>(), 100.0 * r["dataset_rss_ratio"].get<double>(),
        r["peak_gpu_pool_mib"].get<double>(), 100.0 * r["gpu_busy_fraction"].get<double>());
    text << line;
    if (runs[k].draws == DrawList::Indirect) {
      // The cut never leaves the device, so its morphing patches are not counted.
      std::snprintf(line, sizeof line, "  morph %s (the draw list is made on the device)\n",
                    r["morph"].get<std::string>().c_str());
    } else {
      std::snprintf(line, sizeof line, "  morph %s: %.1f patches morphing per frame\n",
                    r["morph"].get<std::string>().c_str(),
                    r["morphing_patches_per_frame_mean"].get<double>());
    }
    text << line;
    if (r.contains("popping_rms_p99")) {
      std::snprintf(line, sizeof line,
                    "  popping (the previous frame's cut drawn with this camera, 0-255): RMS p50 "
                    "%.3f p99 %.3f max %.3f; largest value difference p50 %.0f p99 %.0f max %.0f\n",
                    r["popping_rms_p50"].get<double>(), r["popping_rms_p99"].get<double>(),
                    r["popping_rms_max"].get<double>(), r["popping_max_p50"].get<double>(),
                    r["popping_max_p99"].get<double>(), r["popping_max_max"].get<double>());
      text << line;
    }
    if (r["cold"].get<bool>()) {
      std::snprintf(
          line, sizeof line, "  cold start: %llu pages (%.2f%%) resident after eviction\n",
          static_cast<unsigned long long>(r["resident_after_evict_pages"].get<std::uint64_t>()),
          100.0 * r["resident_after_evict_fraction"].get<double>());
      text << line;
    }
  }
  text << "report: " << (dir / "report.png").string() << ", " << (dir / "summary.json").string()
       << ", " << (dir / "frames.csv").string() << "\n";
  return text.str();
}

}  // namespace pbdam::tools
