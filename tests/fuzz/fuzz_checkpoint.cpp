// libFuzzer target for the build checkpoint's decoders (tools/builder Checkpoint.h, compiled from
// CheckpointPayloads.cpp alone): the first byte picks the state file's text parser or a part
// file of one kind (nodes, carry, texture) — trailer, CRC, then every entry, index lookup and
// carry record the decoders accept. Seeds: the checkpoint of a small MOLA build (`pbdam build
// --dem megt90n000cb.lbl --planet mars --levels 2 --leaf-vertices 9 --min-patch-triangles 16
// --texture-tile 16 --texture-format rgba8`) stopped before its manifest (PBDAM_TEST_FAIL_WRITE=
// manifest) and, for the carry, before level 0 (PBDAM_TEST_FAIL_LEVEL=0), each file prefixed with
// its selector (tests/fuzz/corpus/checkpoint); tests/fuzz/make_seeds.sh rewrites them when the
// checkpoint version changes.
#include <array>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <span>
#include <string_view>

#include "pbdam/builder/Checkpoint.h"
#include "pbdam/formats/Checksum.h"

namespace {

using namespace pbdam::builder;
using pbdam::formats::crc32;

void nodes(std::span<const std::byte> payload) {
  auto view = LevelPartView::parse(payload, "fuzz.nodes");
  if (!view) return;
  (void)view->forEachNode([&](const NodeEntry& entry, std::size_t readSoFar) {
    if (readSoFar > payload.size()) __builtin_trap();
    if (entry.blob.data() < payload.data() ||
        entry.blob.data() + entry.blob.size() > payload.data() + payload.size()) {
      __builtin_trap();
    }
    return true;
  });
}

void textures(std::span<const std::byte> payload) {
  auto view = TexturePartView::parse(payload, "fuzz.tiles");
  if (!view) return;
  (void)view->forEachTile([&](std::uint64_t, float, std::span<const std::byte> colour,
                              std::span<const std::byte> normal) {
    for (const std::span<const std::byte> blob : {colour, normal}) {
      if (blob.data() + blob.size() > payload.data() + payload.size()) __builtin_trap();
    }
    return true;
  });
}

void carry(std::span<const std::byte> payload) {
  auto view = CarryPartView::parse(payload, "fuzz.carry");
  if (!view) return;
  // Look up the ids the payload's own bytes suggest, and a few fixed ones.
  for (std::size_t at = 0; at + 8 <= payload.size() && at < 4096; at += 8) {
    std::uint64_t id = 0;
    std::memcpy(&id, payload.data() + at, 8);
    for (const std::uint64_t candidate : {id, std::uint64_t{at / 8}}) {
      const auto offset = view->offsetOf(candidate);
      if (!offset) continue;
      if (*offset >= payload.size()) __builtin_trap();
      CarrySaturation saturation;
      WorkPatch patch;
      if (view->read(*offset, saturation, &patch)) {
        for (const std::uint32_t index : patch.indices) {
          if (index >= patch.points.size()) __builtin_trap();
        }
      }
      (void)view->read(*offset, saturation, nullptr);
    }
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size < 1) return 0;
  const auto bytes = std::as_bytes(std::span<const std::uint8_t>(data + 1, size - 1));
  const int selector = data[0] % 4;
  if (selector == 0) {
    const std::string_view text(reinterpret_cast<const char*>(data + 1), size - 1);
    (void)parseCheckpointState(text, "fuzz.state");
    return 0;
  }
  const auto kind = static_cast<Checkpoint::Kind>(selector);
  // The trailer names the level and part: read them back so that valid seeds pass the check.
  int level = 0;
  std::uint32_t part = 0;
  if (bytes.size() >= kPartTrailerBytes + 4) {
    const std::byte* trailer = bytes.data() + bytes.size() - kPartTrailerBytes - 4;
    std::memcpy(&level, trailer + 16, 4);
    std::memcpy(&part, trailer + 20, 4);
  }
  auto payload = partPayload(bytes, kind, level, part, "fuzz");
  if (!payload) return 0;
  std::uint32_t stored = 0;
  std::memcpy(&stored, bytes.data() + bytes.size() - 4, 4);
  // Both: with the CRC checked (what a resume reads) and without it (the build's own carry).
  (void)(crc32(bytes.first(bytes.size() - 4)) == stored);
  if (kind == Checkpoint::Kind::Nodes) nodes(*payload);
  if (kind == Checkpoint::Kind::Carry) carry(*payload);
  if (kind == Checkpoint::Kind::Texture) textures(*payload);
  (void)decodeLevelPartFooter(payload->first(std::min<std::size_t>(payload->size(), 48)),
                              "fuzz footer");
  return 0;
}
