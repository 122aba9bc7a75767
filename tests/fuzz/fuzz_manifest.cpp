// libFuzzer target for the manifest reader (Manifest.h): parseManifest on arbitrary text; an
// accepted manifest must write back to JSON that parses to the same JSON again. Text that is a
// JSON object is also read a second time with its checksum made right, so that the fields behind
// the checksum (types, ranges, face names) are explored and not only the checksum test. Seeds:
// the manifest of a small MOLA build and variants (tests/fuzz/corpus/manifest).
#include <cstddef>
#include <cstdint>
#include <nlohmann/json.hpp>
#include <span>
#include <string>
#include <string_view>

#include "pbdam/formats/Checksum.h"
#include "pbdam/formats/Manifest.h"

namespace {

void readAndRewrite(std::string_view text) {
  using namespace pbdam::formats;
  auto manifest = parseManifest(text, "fuzz");
  if (!manifest) return;
  const std::string json = manifestToJson(*manifest);
  auto again = parseManifest(json, "fuzz re-written");
  if (!again) __builtin_trap();
  if (manifestToJson(*again) != json) __builtin_trap();
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string_view text(reinterpret_cast<const char*>(data), size);
  readAndRewrite(text);
  // The checksum as the reader computes it: over the object without it, dumped with indent 2.
  nlohmann::ordered_json j = nlohmann::ordered_json::parse(text, nullptr, false);
  if (j.is_discarded() || !j.is_object()) return 0;
  j.erase("checksum");
  std::string body;
  try {
    body = j.dump(2);  // throws on strings that are not UTF-8, as in the reader, which refuses them
  } catch (const nlohmann::ordered_json::exception&) {
    return 0;
  }
  j["checksum"] = pbdam::formats::crc32(std::as_bytes(std::span(body.data(), body.size())));
  readAndRewrite(j.dump(2));
  return 0;
}
