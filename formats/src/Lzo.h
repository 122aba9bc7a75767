// LZO1X through liblzo2 for the formats module's blobs (patches: formats/PatchBlob.md; texture
// tiles: formats/TextureTile.md): the library's one-time initialisation and its documented
// worst-case output size. Private to pbdam_formats.
#pragma once

#include <lzo/lzo1x.h>

#include <cstddef>

namespace pbdam::formats {

/// Whether liblzo2 is initialised; initialises it on the first call. liblzo2 must be
/// initialised once per process before any (de)compression; the function-local static makes
/// that thread-safe. False only if lzo_init() fails (a miscompiled library).
inline bool lzoReady() noexcept {
  static const bool ready = lzo_init() == LZO_E_OK;
  return ready;
}

/// The most bytes LZO1X can produce for `rawBytes` bytes of input (liblzo2's documented bound
/// n + n/16 + 64 + 3): the room a compressor's output buffer needs, and the largest payload a
/// decoder may accept for `rawBytes` of raw data.
inline std::size_t lzoWorstCaseBytes(std::size_t rawBytes) noexcept {
  return rawBytes + rawBytes / 16 + 64 + 3;
}

}  // namespace pbdam::formats
