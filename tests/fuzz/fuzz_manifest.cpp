// libFuzzer target for the manifest reader (Manifest.h): parseManifest on arbitrary text; an
// accepted manifest must write back to JSON that parses to the same JSON again. Seeds: the
// manifest of a small MOLA build and variants (tests/fuzz/corpus/manifest).
#include <cstddef>
#include <cstdint>
#include <string_view>

#include "pbdam/formats/Manifest.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace pbdam::formats;
  const std::string_view text(reinterpret_cast<const char*>(data), size);
  auto manifest = parseManifest(text, "fuzz");
  if (!manifest) return 0;
  const std::string json = manifestToJson(*manifest);
  auto again = parseManifest(json, "fuzz re-written");
  if (!again) __builtin_trap();
  if (manifestToJson(*again) != json) __builtin_trap();
  return 0;
}
