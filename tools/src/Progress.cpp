// Terminal progress bar / throttled plain progress lines (Progress.h).
#include "Progress.h"

#include <unistd.h>

#include <algorithm>
#include <cmath>

namespace pbdam::tools {

Progress::Progress(bool quiet, std::FILE* stream, OnTerminal onTerminal)
    : quiet_(quiet),
      stream_(stream),
      tty_(::isatty(::fileno(stream)) != 0),
      onTerminal_(onTerminal) {}

Progress::~Progress() { finish(); }

void Progress::update(std::string_view stage, double fraction) {
  if (quiet_) return;
  const auto now = std::chrono::steady_clock::now();
  if (stage != stage_) {
    if (tty_) finish();
    stage_ = stage;
    stageStart_ = now;
  }
  fraction = std::clamp(fraction, 0.0, 1.0);
  if (tty_) {
    drawBar(fraction, now);
    return;
  }
  char line[64];
  std::snprintf(line, sizeof line, " %d%%", static_cast<int>(std::floor(fraction * 100.0)));
  status(stage_ + line);
}

void Progress::status(std::string_view text, bool last) {
  if (quiet_) return;
  if (tty_ && onTerminal_ == OnTerminal::Redraw) {
    const auto now = std::chrono::steady_clock::now();
    if (!last && open_ && now - lastDraw_ < std::chrono::milliseconds(100)) return;
    lastDraw_ = now;
    redraw(std::string(text));
    return;
  }
  if (tty_ || last) {
    printLine(std::string(text));
    return;
  }
  const auto now = std::chrono::steady_clock::now();
  if (drewLine_ && now - lastDraw_ < kLineInterval) {
    pending_ = text;
    return;
  }
  printLine(std::string(text));
}

void Progress::finish() {
  if (open_) {
    std::fputc('\n', stream_);
    std::fflush(stream_);
    open_ = false;
    openWidth_ = 0;
  }
  if (!pending_.empty()) printLine(pending_);
}

void Progress::drawBar(double fraction, std::chrono::steady_clock::time_point now) {
  if (fraction < 1.0 && now - lastDraw_ < std::chrono::milliseconds(100)) return;
  lastDraw_ = now;
  const double elapsed = std::chrono::duration<double>(now - stageStart_).count();
  const double eta = fraction > 0.01 ? elapsed * (1.0 - fraction) / fraction : std::nan("");
  constexpr int kWidth = 30;
  const int filled = static_cast<int>(std::lround(fraction * kWidth));
  std::string bar(static_cast<std::size_t>(filled), '#');
  bar.append(static_cast<std::size_t>(kWidth - filled), '.');
  char line[256];
  if (std::isnan(eta)) {
    std::snprintf(line, sizeof line, "%-10s [%s] %5.1f%%  %6.1fs        ", stage_.c_str(),
                  bar.c_str(), 100.0 * fraction, elapsed);
  } else {
    std::snprintf(line, sizeof line, "%-10s [%s] %5.1f%%  %6.1fs  ETA %5.0fs", stage_.c_str(),
                  bar.c_str(), 100.0 * fraction, elapsed, eta);
  }
  redraw(line);
}

void Progress::redraw(const std::string& text) {
  // Spaces over whatever a longer previous line left behind.
  const std::size_t pad = openWidth_ > text.size() ? openWidth_ - text.size() : 0;
  std::fprintf(stream_, "\r%s%*s", text.c_str(), static_cast<int>(pad), "");
  std::fflush(stream_);
  open_ = true;
  openWidth_ = text.size();
}

void Progress::printLine(const std::string& text) {
  std::fprintf(stream_, "%s\n", text.c_str());
  std::fflush(stream_);
  lastDraw_ = std::chrono::steady_clock::now();
  drewLine_ = true;
  pending_.clear();
}

}  // namespace pbdam::tools
