// Terminal progress bar / plain progress lines (Progress.h).
#include "Progress.h"

#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdio>

namespace pbdam::tools {

Progress::Progress(bool quiet) : quiet_(quiet), tty_(::isatty(STDERR_FILENO) != 0) {}

Progress::~Progress() { finish(); }

void Progress::update(std::string_view stage, double fraction) {
  if (quiet_) return;
  const auto now = std::chrono::steady_clock::now();
  if (stage != stage_) {
    finish();
    stage_ = stage;
    stageStart_ = now;
    lastDecile_ = -1;
  }
  fraction = std::clamp(fraction, 0.0, 1.0);
  if (tty_) {
    if (fraction < 1.0 && now - lastDraw_ < std::chrono::milliseconds(100)) return;
    lastDraw_ = now;
    const double elapsed = std::chrono::duration<double>(now - stageStart_).count();
    const double eta = fraction > 0.01 ? elapsed * (1.0 - fraction) / fraction : std::nan("");
    constexpr int kWidth = 30;
    const int filled = static_cast<int>(std::lround(fraction * kWidth));
    std::string bar(static_cast<std::size_t>(filled), '#');
    bar.append(static_cast<std::size_t>(kWidth - filled), '.');
    if (std::isnan(eta)) {
      std::fprintf(stderr, "\r%-10s [%s] %5.1f%%  %6.1fs        ", stage_.c_str(), bar.c_str(),
                   100.0 * fraction, elapsed);
    } else {
      std::fprintf(stderr, "\r%-10s [%s] %5.1f%%  %6.1fs  ETA %5.0fs", stage_.c_str(), bar.c_str(),
                   100.0 * fraction, elapsed, eta);
    }
    std::fflush(stderr);
    open_ = true;
    return;
  }
  const int decile = static_cast<int>(std::floor(fraction * 10.0));
  if (decile > lastDecile_) {
    lastDecile_ = decile;
    std::fprintf(stderr, "%s %d%%\n", stage_.c_str(), decile * 10);
  }
}

void Progress::finish() {
  if (open_) {
    std::fputc('\n', stderr);
    open_ = false;
  }
}

}  // namespace pbdam::tools
