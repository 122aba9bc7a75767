// Patch codec: the on-disk blob of one P-BDAM patch (quantised barycentric vertices + 16-bit
// triangle list), delta-coded, split into byte planes and LZO-compressed, as in [P-BDAM 2003] §4.4
// ("patches are stored LZO-compressed"). Byte layout: formats/PatchBlob.md.
#pragma once

#include <cstddef>
#include <cstdint>
#include <span>
#include <string_view>
#include <vector>

#include "pbdam/formats/Result.h"

namespace pbdam::formats {

/// One patch vertex (docs/builder.md, "Patches"): barycentric coordinates relative to the node's
/// corners P1 (b1) and P2 (b2) in units of 2^-15 (exact: the vertex is a lattice point), and that
/// lattice point's own height in units of the dataset's height step (h = heightSteps ·
/// heightStep metres; dataset format 2, formats/FORMAT.md).
/// Valid vertices have b1 + b2 <= kPatchBarycentricOne.
struct PatchVertex final {
  std::uint16_t b1 = 0;          ///< weight of P1 (left), 2^-15 units
  std::uint16_t b2 = 0;          ///< weight of P2 (right), 2^-15 units
  std::int32_t heightSteps = 0;  ///< the lattice point's height in height steps

  /// Field by field.
  friend bool operator==(const PatchVertex&, const PatchVertex&) = default;
};

/// A patch's TIN: vertices and a CCW triangle list of 16-bit indices (3 per triangle).
struct PatchMesh final {
  std::vector<PatchVertex> vertices;   ///< at most kMaxPatchVertices
  std::vector<std::uint16_t> indices;  ///< three a triangle, counter-clockwise

  /// Triangles of the mesh (indices / 3).
  std::size_t triangleCount() const noexcept { return indices.size() / 3; }
  /// Vertices and indices equal, in order.
  friend bool operator==(const PatchMesh&, const PatchMesh&) = default;
};

/// Barycentric 1.0 in PatchVertex units (2^15).
inline constexpr std::uint32_t kPatchBarycentricOne = 1U << 15;
/// Most vertices a patch may have (16-bit indices, docs/architecture.md "Measured facts").
inline constexpr std::uint32_t kPatchMaxVertices = 65535;
/// Most triangles a patch blob may declare (a decode-side sanity limit).
inline constexpr std::uint32_t kPatchMaxTriangles = 131072;
/// Size of the fixed blob header in bytes (PatchBlob.md).
inline constexpr std::size_t kPatchBlobHeaderBytes = 32;
/// The blob format version this build writes and reads.
inline constexpr std::uint16_t kPatchBlobVersion = 1;

/// Reorders a patch for drawing with 16-bit indices: triangles for the post-transform vertex
/// cache (meshopt_optimizeVertexCache), then vertices in first-use order
/// (meshopt_optimizeVertexFetch). The set of triangles and their orientation are unchanged;
/// vertices no triangle references are dropped. First-use vertex order is also what makes the
/// index codes small for encodePatch. Deterministic. Indices must be < vertices.size().
void optimizePatchForRendering(PatchMesh& mesh);

/// Which LZO1X compressor encodePatch uses; both produce the same format (PatchBlob.md has the
/// measurements).
enum class PatchCompression {
  Fast,     ///< lzo1x_1 (the default): fastest to encode and to decode
  Compact,  ///< lzo1x_999 level 4: ~6% smaller blobs, 3-7x slower encode, 1.2-1.8x slower decode
};

/// Encodes `mesh` into a self-contained blob (header + LZO1X block, PatchBlob.md). The same mesh
/// and `compression` always give the same bytes. Returns InvalidArgument if the mesh has more than
/// kPatchMaxVertices vertices or kPatchMaxTriangles triangles, an index count that is not a
/// multiple of 3, an index >= the vertex count, or a vertex with b1 + b2 > kPatchBarycentricOne.
/// Thread-safe (uses thread-local work memory).
Result<std::vector<std::byte>> encodePatch(const PatchMesh& mesh,
                                           PatchCompression compression = PatchCompression::Fast);

/// Decodes a blob written by encodePatch into `out`, reusing its capacity (no allocation once
/// it is large enough). Safe to use for untrusted input: every size, the CRC, the LZO stream,
/// every index and every barycentric coordinate are checked, and nothing is read or written out
/// of bounds. On error returns CorruptData (also for another format version) with the message
/// "<context>: <what>" and leaves `out` in a valid but unspecified state. Thread-safe
/// (uses a thread-local scratch buffer).
Result<void> decodePatch(std::span<const std::byte> blob, PatchMesh& out, std::string_view context);

/// What a blob's header declares.
struct PatchBlobInfo final {
  std::uint32_t vertexCount = 0;      ///< vertices of the patch
  std::uint32_t triangleCount = 0;    ///< triangles of the patch
  std::uint32_t compressedBytes = 0;  ///< size of the LZO block (blob size - header)
  std::uint32_t rawBytes = 0;         ///< size of the payload before compression
  std::uint32_t wideIndexCount = 0;   ///< index codes >= 15, stored as 16 bits (PatchBlob.md)
};

/// Reads and checks a blob's header only (magic, version, size limits, sizes consistent with
/// the blob's length) without verifying the CRC or decompressing: for statistics such as
/// `pbdam info`. Errors as for decodePatch.
Result<PatchBlobInfo> inspectPatchBlob(std::span<const std::byte> blob, std::string_view context);

/// Size of the morph-target blob's header in bytes (PatchBlob.md, "Morph targets").
inline constexpr std::size_t kMorphBlobHeaderBytes = 16;
/// The morph-target blob format version this build writes and reads.
inline constexpr std::uint16_t kMorphBlobVersion = 1;

/// Encodes the morph targets of `mesh` (docs/builder.md "Morph targets"): `targets[i]` is the
/// height, in height steps, of the coarser surface that vertex i of `mesh` morphs from. Stored
/// as zigzag differences to the vertex's own height in byte planes, LZO1X-compressed (vertices
/// the coarser surface passes through cost nothing). The same inputs give the same bytes.
/// InvalidArgument when the counts differ or the mesh has more than kPatchMaxVertices vertices.
Result<std::vector<std::byte>> encodeMorphTargets(const PatchMesh& mesh,
                                                  std::span<const std::int32_t> targets);

/// Decodes a morph-target blob of the patch `mesh` into `out` (one height per vertex, reusing
/// its capacity). An empty blob means every target is the vertex's own height (a root patch,
/// which has no coarser surface). Safe for untrusted input: the header, the vertex count
/// against `mesh`, the CRC and the LZO stream are checked; CorruptData "<context>: <what>".
Result<void> decodeMorphTargets(std::span<const std::byte> blob, const PatchMesh& mesh,
                                std::vector<std::int32_t>& out, std::string_view context);

}  // namespace pbdam::formats
