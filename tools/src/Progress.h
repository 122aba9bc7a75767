// Progress reporting for long commands: a redrawn bar with percentage and ETA on a terminal,
// plain "stage NN%" lines (at most one per 10%) when stderr is not a TTY. Thread-safety: call
// from one thread.
#pragma once

#include <chrono>
#include <string>
#include <string_view>

namespace pbdam::tools {

class Progress final {
 public:
  explicit Progress(bool quiet = false);
  ~Progress();
  Progress(const Progress&) = delete;
  Progress& operator=(const Progress&) = delete;

  /// Reports `fraction` (0..1) of `stage` done.
  void update(std::string_view stage, double fraction);
  /// Ends the current line (a terminal bar is left showing 100%).
  void finish();

 private:
  bool quiet_;
  bool tty_;
  std::string stage_;
  int lastDecile_ = -1;
  std::chrono::steady_clock::time_point stageStart_;
  std::chrono::steady_clock::time_point lastDraw_;
  bool open_ = false;
};

}  // namespace pbdam::tools
