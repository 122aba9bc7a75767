// Image files through OpenImageIO, in a module loaded on first use (libpbdam_oiio.so, built
// beside the pbdam executable). Debian's OpenImageIO links about 260 shared libraries (OpenCV,
// FFmpeg, DCMTK, OpenVDB, ...): loading them took 0.12 s of every process start, 0.2 s under the
// sanitizers, while most pbdam commands never read or write an image. The module is looked for
// beside the running executable, then by name through the dynamic linker (Module.h): installed,
// it is libpbdam_oiio.so in the package's lib directory.
// Thread-safety: imageCodec() is safe from any thread; the codec's functions are reentrant.
#pragma once

#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include "pbdam/formats/Result.h"

namespace pbdam::formats {

/// Pixels of 8-bit channels, `channels` bytes a pixel, rows top to bottom, tightly packed.
struct Pixels8 final {
  std::int64_t width = 0;           ///< pixels a row
  std::int64_t height = 0;          ///< rows
  int channels = 0;                 ///< 1 to 4
  std::vector<std::uint8_t> bytes;  ///< width·height·channels
};

/// RGBA8 pixels to encode (not owned): 4 bytes a pixel, rows top to bottom, tightly packed.
struct RgbaPixels final {
  const std::uint8_t* rgba = nullptr;  ///< width·height·4 bytes
  std::uint32_t width = 0;             ///< pixels a row
  std::uint32_t height = 0;            ///< rows
};

/// Linear RGB floats to write (not owned): 3 floats a pixel, rows top to bottom.
struct LinearRgbPixels final {
  const float* rgb = nullptr;  ///< width·height·3 values
  std::uint32_t width = 0;     ///< pixels a row
  std::uint32_t height = 0;    ///< rows
};

/// The module's functions. Their errors carry OpenImageIO's message; callers add the file name.
struct ImageCodec final {
  /// Reads up to four channels of an image file (any format OpenImageIO reads) as 8 bits.
  /// UnsupportedFormat: not an image, or an unusable layout; CorruptData: the pixels do not
  /// decode, including a decoder's warning about a truncated file.
  Result<Pixels8> (*read)(const std::filesystem::path& path);
  /// Writes the first `channels` (3 or 4) channels of `image` to `file`, in the format its
  /// extension names: 8 bits (PNG at zlib level 1), or with `halfFloat` half floats with values
  /// 0..1 (EXR). IoError.
  Result<void> (*write)(const std::filesystem::path& file, RgbaPixels image, int channels,
                        bool halfFloat);
  /// Encodes the first `channels` (3 or 4) channels in memory as `format` ("png": zlib level 1,
  /// the bytes `write` gives; "jpg": baseline at `jpegQuality`, 1..100). Internal on failure.
  Result<std::vector<unsigned char>> (*encode)(RgbaPixels image, const std::string& format,
                                               int channels, int jpegQuality);
  /// Writes linear RGB floats to `file` as a half-float EXR (values as given, unclamped), with
  /// the attribute `extraName` = `extraValue` (a float) when `extraName` is not empty. IoError.
  Result<void> (*writeLinear)(const std::filesystem::path& file, LinearRgbPixels image,
                              const std::string& extraName, float extraValue);
  /// Draws `lines` in `fontFile` (OpenImageIO's default font when empty) at `fontPixels`, ink
  /// on an opaque dark panel just large enough for them and at most `maxWidth` wide, as RGBA.
  Pixels8 (*drawText)(const std::vector<std::string>& lines, const std::string& fontFile,
                      std::uint32_t maxWidth, int fontPixels);
};

/// The codec, loaded on the first call. Internal error naming the places looked in and why when
/// the module is missing or does not load.
Result<const ImageCodec*> imageCodec();

}  // namespace pbdam::formats
