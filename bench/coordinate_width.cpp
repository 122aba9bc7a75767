// What wider patch coordinates would cost: every patch of a dataset decoded and its payload laid
// out twice as formats/PatchBlob.md does — barycentrics b1, b2 in units of 2^-15 of the patch's
// legs (two byte planes each, the stored format) and in units of 2^-23 (three planes each: the
// widening that would let a patch address a lattice 2^8 times finer than its legs' 2^-15 steps),
// heights and index codes identical — and both compressed with lzo1x_1. Prints, per bintree
// level and in all, triangles, stored bytes, and the compressed bytes of both layouts per
// triangle. The 2^-23 values are today's coordinates scaled by 2^8 (the data has no finer
// points); on a deeper lattice only the coarsest levels' patches would use the extra bits.
//   build/release/bench/pbdam_coordinate_width DATASET_DIR
#include <lzo/lzo1x.h>

#include <bit>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <filesystem>
#include <map>
#include <string>
#include <vector>

#include "pbdam/formats/DatasetFormat.h"
#include "pbdam/formats/Manifest.h"
#include "pbdam/formats/MemoryMapping.h"
#include "pbdam/formats/PatchCodec.h"

using namespace pbdam::formats;

namespace {

/// Appends `planes` byte planes of `values` (byte 0 of every value, then byte 1, ...).
void appendPlanes(std::vector<unsigned char>& out, const std::vector<std::uint32_t>& values,
                  int planes) {
  for (int p = 0; p < planes; ++p) {
    for (const std::uint32_t v : values) out.push_back(static_cast<unsigned char>(v >> (8 * p)));
  }
}

/// Zigzag of a `bits`-bit wrapping delta, as PatchBlob.md codes it.
std::uint32_t zigzag(std::int64_t delta, int bits) {
  const std::uint64_t mask = (std::uint64_t{1} << bits) - 1;
  const auto wrapped = static_cast<std::uint64_t>(delta) & mask;
  // Sign-extend the wrapped value, then (d << 1) ^ (d >> (bits - 1)) within `bits` bits.
  const std::int64_t d = (wrapped >> (bits - 1)) != 0
                             ? static_cast<std::int64_t>(wrapped) - (std::int64_t{1} << bits)
                             : static_cast<std::int64_t>(wrapped);
  return static_cast<std::uint32_t>(
      ((static_cast<std::uint64_t>(d) << 1) ^ static_cast<std::uint64_t>(d >> 63)) & mask);
}

/// The payload of `mesh` with barycentrics scaled by 2^`shift` and stored in `planes` planes.
std::vector<unsigned char> payload(const PatchMesh& mesh, int shift, int planes) {
  std::vector<unsigned char> out;
  const int bits = 8 * planes;
  for (int coordinate = 0; coordinate < 2; ++coordinate) {
    std::vector<std::uint32_t> codes;
    std::int64_t previous = 0;
    for (const PatchVertex& v : mesh.vertices) {
      const std::int64_t b = std::int64_t{coordinate == 0 ? v.b1 : v.b2} << shift;
      codes.push_back(zigzag(b - previous, bits));
      previous = b;
    }
    appendPlanes(out, codes, planes);
  }
  std::vector<std::uint32_t> heights;
  std::int64_t previous = 0;
  for (const PatchVertex& v : mesh.vertices) {
    heights.push_back(zigzag(std::int64_t{v.heightSteps} - previous, 32));
    previous = v.heightSteps;
  }
  appendPlanes(out, heights, 4);
  // Index codes: a nibble each, 15 escapes to a 16-bit wide code (PatchBlob.md "Indices").
  std::vector<unsigned char> nibbles((mesh.indices.size() + 1) / 2, 0);
  std::vector<std::uint32_t> wide;
  std::uint32_t seen = 0;
  for (std::size_t k = 0; k < mesh.indices.size(); ++k) {
    const std::uint32_t code = (seen - mesh.indices[k]) & 0xFFFFu;
    if (code == 0) ++seen;
    const std::uint32_t nibble = code < 15 ? code : 15;
    if (nibble == 15) wide.push_back(code);
    nibbles[k / 2] = static_cast<unsigned char>(nibbles[k / 2] | (nibble << (4 * (k % 2))));
  }
  out.insert(out.end(), nibbles.begin(), nibbles.end());
  appendPlanes(out, wide, 2);
  return out;
}

std::size_t lzoBytes(const std::vector<unsigned char>& raw) {
  static std::vector<unsigned char> work(LZO1X_1_MEM_COMPRESS);
  std::vector<unsigned char> out(raw.size() + raw.size() / 16 + 64 + 3);
  lzo_uint outBytes = 0;
  if (lzo1x_1_compress(raw.data(), raw.size(), out.data(), &outBytes, work.data()) != LZO_E_OK) {
    std::fprintf(stderr, "lzo1x_1_compress failed\n");
    std::exit(2);
  }
  return outBytes;
}

struct Totals final {
  std::uint64_t patches = 0, triangles = 0, vertices = 0;
  std::uint64_t stored = 0, narrow = 0, wide = 0, narrowRaw = 0, wideRaw = 0;
};

int run(int argc, char** argv) {
  if (argc != 2 || std::string(argv[1]) == "--help") {
    std::fprintf(stderr, "usage: pbdam_coordinate_width DATASET_DIR\n");
    return argc == 2 ? 0 : 2;
  }
  if (lzo_init() != LZO_E_OK) return 2;
  const std::filesystem::path dir = argv[1];
  auto manifest = readManifest(dir);
  if (!manifest) {
    std::fprintf(stderr, "%s\n", manifest.error().message.c_str());
    return 2;
  }
  std::map<int, Totals> levels;
  Totals all;
  PatchMesh mesh;
  std::vector<std::byte> buffer;
  for (const auto& face : manifest->faces) {
    auto file = MemoryMapping::open(dir / face.file);
    if (!file) {
      std::fprintf(stderr, "%s\n", file.error().message.c_str());
      return 2;
    }
    auto view = FaceView::open(file->bytes(), face.file);
    if (!view) {
      std::fprintf(stderr, "%s\n", view.error().message.c_str());
      return 2;
    }
    for (std::uint64_t k = 0; k < view->header().nodeCount; ++k) {
      const NodeRecord node = view->nodeAt(k);
      const auto blob = view->readPatchBlob(node, buffer);
      if (!blob || !decodePatch(*blob, mesh, face.file)) {
        std::fprintf(stderr, "%s: node %llu does not decode\n", face.file.c_str(),
                     static_cast<unsigned long long>(k));
        return 2;
      }
      const std::vector<unsigned char> narrow = payload(mesh, 0, 2);
      const std::vector<unsigned char> wide = payload(mesh, 8, 3);
      for (Totals* t : {&levels[static_cast<int>(std::bit_width(node.heapIndex + 1)) - 1], &all}) {
        ++t->patches;
        t->triangles += mesh.triangleCount();
        t->vertices += mesh.vertices.size();
        t->stored += blob->size();
        t->narrowRaw += narrow.size();
        t->wideRaw += wide.size();
        t->narrow += lzoBytes(narrow) + kPatchBlobHeaderBytes;
        t->wide += lzoBytes(wide) + kPatchBlobHeaderBytes;
      }
    }
  }
  std::printf("%s: bytes per triangle of the patch blobs (header included), lzo1x_1\n",
              dir.string().c_str());
  std::printf(
      "level  patches  triangles  stored  2^-15 (2 planes)  2^-23 (3 planes)  wider/stored\n");
  const auto row = [](const char* label, const Totals& t) {
    const auto perTriangle = [&](std::uint64_t bytes) {
      return static_cast<double>(bytes) / static_cast<double>(t.triangles);
    };
    std::printf("%5s %8llu %10llu %7.3f %17.3f %17.3f %13.3f\n", label,
                static_cast<unsigned long long>(t.patches),
                static_cast<unsigned long long>(t.triangles), perTriangle(t.stored),
                perTriangle(t.narrow), perTriangle(t.wide),
                static_cast<double>(t.wide) / static_cast<double>(t.stored));
  };
  for (const auto& [level, t] : levels) row(std::to_string(level).c_str(), t);
  row("all", all);
  std::printf(
      "raw payload per triangle: %.3f (2^-15) vs %.3f (2^-23) bytes; %.3f vertices a "
      "triangle\n",
      static_cast<double>(all.narrowRaw) / static_cast<double>(all.triangles),
      static_cast<double>(all.wideRaw) / static_cast<double>(all.triangles),
      static_cast<double>(all.vertices) / static_cast<double>(all.triangles));
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  try {
    return run(argc, argv);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "pbdam_coordinate_width: %s\n", e.what());
    return 2;
  }
}
