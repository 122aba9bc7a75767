// libFuzzer target for the camera-path CSV reader (CameraPath.h): parseCameraPath on arbitrary
// text; an accepted path must format back to CSV that parses to as many points. Seeds: the
// beginnings of bench/paths/*.csv and edge cases (tests/fuzz/corpus/camera_path).
#include <cstddef>
#include <cstdint>
#include <string_view>

#include "pbdam/formats/CameraPath.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace pbdam::formats;
  const std::string_view text(reinterpret_cast<const char*>(data), size);
  auto points = parseCameraPath(text, "fuzz");
  if (!points) return 0;
  auto again = parseCameraPath(formatCameraPath(*points), "fuzz re-written");
  if (!again || again->size() != points->size()) __builtin_trap();
  return 0;
}
