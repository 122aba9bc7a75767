// The CPU seconds each stage of a build took (BuildSummary::cpuSeconds, which `pbdam build`
// prints per stage): the process's CPU clock (user + system) read at the end of every stage.
// Private to the builder. Thread-safety: none; the thread that runs the stages owns it.
#pragma once

#include <string>

#include "pbdam/builder/Builder.h"

namespace pbdam::builder {

class StageClock final {
 public:
  /// Starts counting from the CPU time this process has used so far.
  StageClock() noexcept;

  /// Appends the CPU seconds since the last mark (or the start) to the summary's stages, named
  /// `stage`, and starts the next stage's count.
  void mark(BuildSummary& summary, std::string stage);

 private:
  /// CPU seconds (user + system) this process has used so far.
  static double processCpuSeconds() noexcept;

  double since_;
};

}  // namespace pbdam::builder
