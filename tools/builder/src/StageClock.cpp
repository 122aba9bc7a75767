// The CPU seconds of each build stage (StageClock.h).
#include "StageClock.h"

#include <ctime>
#include <utility>

namespace pbdam::builder {

StageClock::StageClock() noexcept : since_(processCpuSeconds()) {}

double StageClock::processCpuSeconds() noexcept {
  timespec t{};
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &t);
  return static_cast<double>(t.tv_sec) + 1e-9 * static_cast<double>(t.tv_nsec);
}

void StageClock::mark(BuildSummary& summary, std::string stage) {
  const double now = processCpuSeconds();
  summary.cpuSeconds.emplace_back(std::move(stage), now - since_);
  since_ = now;
}

}  // namespace pbdam::builder
