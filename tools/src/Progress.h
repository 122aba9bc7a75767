// Progress reporting for long commands: a redrawn line (a bar with percentage and ETA, or a
// status text) on a terminal; without a terminal, plain lines at most one per second plus the
// final one, so logs of long runs stay short. Thread-safety: call from one thread.
#pragma once

#include <chrono>
#include <cstdio>
#include <string>
#include <string_view>

namespace pbdam::tools {

class Progress final {
 public:
  /// How status lines look on a terminal: redrawn in place, or each one printed (for lines the
  /// user reads, such as per-frame statistics). Without a terminal both are throttled alike.
  enum class OnTerminal { Redraw, Scroll };

  /// `stream` must outlive the Progress; quiet prints nothing at all.
  explicit Progress(bool quiet = false, std::FILE* stream = stderr,
                    OnTerminal onTerminal = OnTerminal::Redraw);
  ~Progress();
  Progress(const Progress&) = delete;
  Progress& operator=(const Progress&) = delete;

  /// Reports `fraction` (0..1) of `stage` done.
  void update(std::string_view stage, double fraction);
  /// Reports a free-form status line (e.g. "frame 12/300 ..."); `last` marks the final one of
  /// the run, which is always printed.
  void status(std::string_view text, bool last = false);
  /// Ends the current line: a terminal line is left showing; without a terminal, the latest
  /// report that the one-line-per-second limit held back is printed.
  void finish();

  /// Minimum time between two lines when the stream is not a terminal.
  static constexpr std::chrono::seconds kLineInterval{1};

 private:
  void drawBar(double fraction, std::chrono::steady_clock::time_point now);
  void redraw(const std::string& text);
  void printLine(const std::string& text);

  bool quiet_;
  std::FILE* stream_;
  bool tty_;
  OnTerminal onTerminal_;
  std::string stage_;
  std::chrono::steady_clock::time_point stageStart_;
  std::chrono::steady_clock::time_point lastDraw_;
  bool drewLine_ = false;  // a line was printed without a terminal (lastDraw_ is its time)
  bool open_ = false;      // a redrawn terminal line is showing
  std::size_t openWidth_ = 0;
  std::string pending_;  // held back by the one-line-per-second limit
};

}  // namespace pbdam::tools
