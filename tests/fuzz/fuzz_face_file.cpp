// libFuzzer target for the face-file reader (DatasetFormat.h): FaceView::open on arbitrary bytes,
// with the node table held whole and paged (the same verdict, the same records, links and
// lookups), then every node and texture record and every patch blob it accepts. Must never crash,
// read out of bounds or hang; accepted files must be internally consistent (every record found by
// its key, children where the table says). Seeds: tiny valid face files
// (tests/fuzz/corpus/face_file, faces 0 and 4 of a depth-0 build of a synthetic DEM: an 8 × 4
// int16le global grid of 1000·sin(0.7·i) + 500·cos(1.3·j), built with `pbdam build --raw-size
// 8,4 --raw-type int16le --bounds -90,-180,90,180 --planet mars --levels 0 --leaf-vertices 3
// --texture-tile 16 --texture-format rgba8`, and face 0 of the same with `--deep-region
// -2,-36,2,-32@6`, a sparse forest; tests/fuzz/make_seeds.sh rewrites them when the face format
// version changes).
#include <array>
#include <cstddef>
#include <cstdint>
#include <span>
#include <vector>

#include "pbdam/formats/DatasetFormat.h"
#include "pbdam/formats/PatchCodec.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const auto bytes = std::as_bytes(std::span<const std::uint8_t>(data, size));
  auto view = pbdam::formats::FaceView::open(bytes, "fuzz");
  // The same bytes with the node table paged through the smallest cache: accepted or refused
  // alike, and every record the same.
  pbdam::formats::FaceViewOptions paging;
  paging.nodeCacheBytes = 1;
  auto paged = pbdam::formats::FaceView::open(bytes, "fuzz", paging);
  if (view.ok() != paged.ok()) __builtin_trap();
  if (!view) return 0;
  std::array<std::byte, pbdam::formats::kNodeRecordBytes> a{};
  std::array<std::byte, pbdam::formats::kNodeRecordBytes> b{};
  for (std::uint64_t k = 0; k < view->header().nodeCount; ++k) {
    pbdam::formats::encodeNodeRecord(view->nodeAt(k), a);
    pbdam::formats::encodeNodeRecord(paged->nodeAt(k), b);
    const std::uint32_t tree = k >= view->treeFirstNode(1) ? 1 : 0;
    const std::uint64_t heap = view->nodeAt(k).heapIndex;
    if (a != b || paged->findNode(tree, heap) != k ||
        paged->findNode(tree, 2 * heap + 1) != view->findNode(tree, 2 * heap + 1) ||
        (!view->nodeAt(k).leaf() && paged->firstChildOf(k) != view->firstChildOf(k))) {
      __builtin_trap();
    }
  }
  if (paged->damage()) __builtin_trap();
  pbdam::formats::PatchMesh mesh;
  std::vector<std::byte> buffer;
  std::vector<std::int32_t> targets;
  for (std::uint64_t k = 0; k < view->header().nodeCount; ++k) {
    const pbdam::formats::NodeRecord node = view->nodeAt(k);
    // An accepted table is a forest: every record is found by its key, inner nodes have their
    // two children next to each other.
    const std::uint32_t tree = k >= view->treeFirstNode(1) ? 1 : 0;
    if (view->findNode(tree, node.heapIndex) != k) __builtin_trap();
    if (!node.leaf()) {
      const std::uint64_t child = view->firstChildOf(k);
      if (child + 1 >= view->header().nodeCount ||
          view->nodeAt(child).heapIndex != 2 * node.heapIndex + 1 ||
          view->nodeAt(child + 1).heapIndex != 2 * node.heapIndex + 2) {
        __builtin_trap();
      }
    }
    const auto blobs = view->readPatchBlobs(node, buffer);
    if (!blobs || blobs->patch.size() != node.blobBytes || blobs->morph.size() != node.morphBytes) {
      __builtin_trap();
    }
    if (pbdam::formats::decodePatch(blobs->patch, mesh, "fuzz")) {
      (void)pbdam::formats::decodeMorphTargets(blobs->morph, mesh, targets, "fuzz");
    }
  }
  for (std::uint64_t k = 0; k < view->header().textureNodeCount; ++k) {
    const auto record = view->textureAt(k);
    if (view->findTexture(record.heapIndex) != k) __builtin_trap();
    const auto blobs = view->readTextureBlobs(record, buffer);
    if (!blobs || blobs->colour.size() != record.blobBytes ||
        blobs->normal.size() != record.normalBytes) {
      __builtin_trap();
    }
  }
  return 0;
}
