// GDAL's error messages collected for the duration of one read instead of printed, and joined
// into pbdam's messages. Private to pbdam_formats (DemReader.cpp, DemHeights.cpp).
// Thread-safety: GDAL's error handler stack is per thread; use a capture on its own thread.
#pragma once

#include <cpl_error.h>

#include <string>
#include <vector>

namespace pbdam::formats {

/// Collects GDAL's error messages for the duration of one read instead of printing them.
class GdalErrorCapture final {
 public:
  GdalErrorCapture() { CPLPushErrorHandlerEx(&GdalErrorCapture::handler, this); }
  ~GdalErrorCapture() { CPLPopErrorHandler(); }
  GdalErrorCapture(const GdalErrorCapture&) = delete;
  GdalErrorCapture& operator=(const GdalErrorCapture&) = delete;

  /// The collected failures (warnings excluded), joined; empty when there were none.
  std::string failures() const {
    std::string joined;
    for (const auto& m : failures_) joined += (joined.empty() ? "" : "; ") + m;
    return joined;
  }
  bool hasFailures() const noexcept { return !failures_.empty(); }
  /// Forgets the failures collected so far (of an attempt that the caller recovered from).
  void clear() noexcept { failures_.clear(); }

 private:
  static void CPL_STDCALL handler(CPLErr level, CPLErrorNum, const char* message) {
    auto* self = static_cast<GdalErrorCapture*>(CPLGetErrorHandlerUserData());
    if (self != nullptr && level >= CE_Failure && message != nullptr) {
      self->failures_.emplace_back(message);
    }
  }
  std::vector<std::string> failures_;
};

/// `what`, followed by GDAL's failures in parentheses when it reported any.
inline std::string withGdal(const std::string& what, const GdalErrorCapture& capture) {
  return capture.hasFailures() ? what + " (GDAL: " + capture.failures() + ")" : what;
}

}  // namespace pbdam::formats
