// Test aid: a copy of a built dataset whose forests stop at different depths in different places
// (what adaptive depth makes), written by keeping only part of each face file's trees: a node
// keeps its two children where `splitNode` says so (and the source has them), a tile its four
// where `splitTile` says so. The patches, errors and spheres are the source's, so every cut of
// the pruned forest is a cut of the complete one: conforming when `splitNode` is closed (a
// diamond's two triangles split alike, and a split diamond's parents split).
#pragma once

#include <gtest/gtest.h>

#include <algorithm>
#include <deque>
#include <filesystem>
#include <fstream>
#include <functional>
#include <span>
#include <string>
#include <vector>

#include "pbdam/formats/Checksum.h"
#include "pbdam/formats/DatasetFormat.h"
#include "pbdam/formats/Manifest.h"
#include "pbdam/runtime/Bintree.h"

namespace pbdam::test {

struct PruneRules final {
  /// Whether this node keeps its children.
  std::function<bool(const runtime::BinTriangle&)> splitNode;
  /// Whether tile (face, level, qi, qj) keeps its children.
  std::function<bool(int, std::uint32_t, std::uint32_t, std::uint32_t)> splitTile;
};

inline std::vector<std::byte> readAll(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  std::vector<char> chars((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  std::vector<std::byte> bytes(chars.size());
  std::memcpy(bytes.data(), chars.data(), chars.size());
  return bytes;
}

inline void writeAll(const std::filesystem::path& path, std::span<const std::byte> bytes) {
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  out.write(reinterpret_cast<const char*>(bytes.data()),
            static_cast<std::streamsize>(bytes.size()));
  ASSERT_TRUE(out.good()) << path;
}

/// The pruned face file of `view` (its bytes `file`).
inline std::vector<std::byte> prunedFace(const formats::FaceView& view, int face,
                                         const PruneRules& rules) {
  using namespace formats;
  const FaceHeader& source = view.header();
  std::vector<NodeRecord> nodes;
  std::uint64_t tree1First = 0;
  for (std::uint32_t tree = 0; tree < 2; ++tree) {
    if (tree == 1) tree1First = nodes.size();
    // Breadth-first from the root: ascending heap order.
    std::deque<std::pair<runtime::BinTriangle, std::uint64_t>> queue;
    queue.emplace_back(runtime::bintreeRoot(source.latticeCells, face, static_cast<int>(tree)),
                       view.treeFirstNode(tree));
    while (!queue.empty()) {
      const auto [t, row] = queue.front();
      queue.pop_front();
      NodeRecord n = view.nodeAt(row);
      const bool split = !n.leaf() && rules.splitNode(t);
      n.flags = split ? 0 : kRecordLeaf;
      nodes.push_back(n);
      if (!split) continue;
      const auto kids = runtime::bintreeChildren(t);
      queue.emplace_back(kids[0], view.firstChildOf(row));
      queue.emplace_back(kids[1], view.firstChildOf(row) + 1);
    }
  }
  std::vector<TextureRecord> tiles;
  std::deque<std::array<std::uint32_t, 3>> queue{{0, 0, 0}};
  while (!queue.empty()) {
    const auto [level, qi, qj] = queue.front();
    queue.pop_front();
    TextureRecord r = view.textureNode(textureHeapIndex(level, qi, qj));
    const bool split = !r.leaf() && rules.splitTile(face, level, qi, qj);
    r.flags = split ? 0 : kRecordLeaf;
    tiles.push_back(r);
    if (!split) continue;
    for (std::uint32_t c = 0; c < 4; ++c)
      queue.push_back({level + 1, 2 * qi + (c & 1), 2 * qj + (c >> 1)});
  }
  std::sort(tiles.begin(), tiles.end(), [](const TextureRecord& a, const TextureRecord& b) {
    return a.heapIndex < b.heapIndex;
  });

  FaceHeader h = source;
  h.nodeCount = nodes.size();
  h.tree1FirstNode = tree1First;
  h.textureNodeCount = tiles.size();
  h.nodeTableOffset = kFaceHeaderBytes;
  h.textureTableOffset = h.nodeTableOffset + h.nodeCount * kNodeRecordBytes;
  const std::uint64_t tablesEnd = h.textureTableOffset + h.textureNodeCount * kTextureRecordBytes;
  h.blobsOffset = (tablesEnd + 4095) / 4096 * 4096;
  std::vector<std::byte> blobs;
  std::vector<std::byte> buffer;
  for (NodeRecord& n : nodes) {  // the patch blob and its morph targets, adjacent
    const auto both = view.readPatchBlobs(n, buffer);
    EXPECT_TRUE(both.ok());
    n.blobOffset = h.blobsOffset + blobs.size();
    if (!both.ok()) continue;
    blobs.insert(blobs.end(), both->patch.begin(), both->patch.end());
    blobs.insert(blobs.end(), both->morph.begin(), both->morph.end());
  }
  for (TextureRecord& t : tiles) {  // the colour tile and its normal map, adjacent
    const auto both = view.readTextureBlobs(t, buffer);
    EXPECT_TRUE(both.ok());
    t.blobOffset = h.blobsOffset + blobs.size();
    if (!both.ok()) continue;
    blobs.insert(blobs.end(), both->colour.begin(), both->colour.end());
    blobs.insert(blobs.end(), both->normal.begin(), both->normal.end());
  }
  h.fileBytes = h.blobsOffset + blobs.size();
  std::vector<std::byte> out(h.fileBytes);
  const auto nodeTable = std::span(out).subspan(h.nodeTableOffset, h.nodeCount * kNodeRecordBytes);
  for (std::size_t k = 0; k < nodes.size(); ++k) {
    encodeNodeRecord(nodes[k], nodeTable.subspan(k * kNodeRecordBytes).first<kNodeRecordBytes>());
  }
  const auto textureTable =
      std::span(out).subspan(h.textureTableOffset, h.textureNodeCount * kTextureRecordBytes);
  for (std::size_t k = 0; k < tiles.size(); ++k) {
    encodeTextureRecord(tiles[k],
                        textureTable.subspan(k * kTextureRecordBytes).first<kTextureRecordBytes>());
  }
  h.nodeTableCrc = crc32(nodeTable);
  h.textureTableCrc = crc32(textureTable);
  encodeFaceHeader(h, std::span(out).first<kFaceHeaderBytes>());
  std::copy(blobs.begin(), blobs.end(), out.begin() + static_cast<std::ptrdiff_t>(h.blobsOffset));
  return out;
}

/// Writes the pruned copy of dataset `from` into directory `to` (face files and manifest).
inline void writePrunedDataset(const std::filesystem::path& from, const std::filesystem::path& to,
                               const PruneRules& rules) {
  using namespace formats;
  auto manifest = readManifest(from);
  ASSERT_TRUE(manifest.ok()) << manifest.error().message;
  std::filesystem::create_directories(to);
  Manifest m = *manifest;
  for (int f = 0; f < 6; ++f) {
    const auto fi = static_cast<std::size_t>(f);
    const std::vector<std::byte> bytes = readAll(from / m.faces[fi].file);
    auto view = FaceView::open(bytes, m.faces[fi].file);
    ASSERT_TRUE(view.ok()) << view.error().message;
    const std::vector<std::byte> pruned = prunedFace(*view, f, rules);
    writeAll(to / m.faces[fi].file, pruned);
    m.faces[fi].bytes = pruned.size();
    m.faces[fi].crc32 = crc32(pruned);
  }
  const std::string json = manifestToJson(m);
  writeAll(to / kManifestFileName, std::as_bytes(std::span<const char>(json.data(), json.size())));
}

}  // namespace pbdam::test
