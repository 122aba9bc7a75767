// Writing rendered frames to image files for `pbdam render` (and later `pbdam serve`): PNG at
// zlib level 1 (docs/architecture.md "Measured facts": the default level cost ~4× the time for ~10%
// smaller files) or half-float EXR (display colour 0..1, or a frame's linear radiance), through
// OpenImageIO. Thread-safety: pure functions.
#pragma once

#include <cstdint>
#include <filesystem>
#include <vector>

#include "pbdam/formats/Result.h"
#include "pbdam/gpu/RgbaImage.h"

namespace pbdam::tools {

/// True when `path` ends in .exr (any case): written as EXR, else as PNG.
bool isExrPath(const std::filesystem::path& path);

/// Writes the RGB channels of `image` (top row first) to `path`: PNG (8-bit, compression level
/// 1) or, for .exr, half-float EXR with values 0..1. Written under a temporary name and renamed,
/// so an interrupted run never leaves a truncated frame. IoError naming the file on failure.
formats::Result<void> writeFrameImage(const std::filesystem::path& path,
                                      const gpu::RgbaImage& image);

/// Writes a frame's linear radiance (RenderedFrame::radiance: RGB floats, `width` · `height`,
/// top row first) to `path` as a half-float EXR, unclamped, with the frame's exposure as its
/// `pbdam:exposure` attribute (the PNG of the same frame is 1 − e^(−radiance · exposure),
/// sRGB-encoded). Under a temporary name and renamed, as writeFrameImage. IoError naming the
/// file on failure.
formats::Result<void> writeFrameRadiance(const std::filesystem::path& path, std::uint32_t width,
                                         std::uint32_t height, const std::vector<float>& radiance,
                                         float exposure);

/// In-memory image encodings (`pbdam serve`).
enum class FrameEncoding { Png, Jpeg };

/// Encodes the RGB channels of `image` in memory: PNG with the settings writeFrameImage uses
/// (the same bytes as the file it writes), or baseline JPEG at `jpegQuality` (1..100). Internal
/// error when the encoder fails.
formats::Result<std::vector<unsigned char>> encodeFrameImage(const gpu::RgbaImage& image,
                                                             FrameEncoding encoding,
                                                             int jpegQuality = 90);

/// All four channels of `image` as a PNG (an overlay with transparency).
formats::Result<std::vector<unsigned char>> encodeRgbaPng(const gpu::RgbaImage& image);

}  // namespace pbdam::tools
