// Frame export through the OpenImageIO module (FrameImage.h, ImageCodec.h).
#include "FrameImage.h"

#include <algorithm>
#include <cctype>
#include <string>
#include <system_error>

#include "pbdam/formats/ImageCodec.h"

using namespace pbdam::formats;

namespace pbdam::tools {

bool isExrPath(const std::filesystem::path& path) {
  std::string ext = path.extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return ext == ".exr";
}

namespace {

RgbaPixels pixelsOf(const gpu::RgbaImage& image) {
  return RgbaPixels{image.rgba.data(), image.widthPixels, image.heightPixels};
}

/// Writes `path` through `write(codec, temporary)` under a temporary name (keeping the
/// extension: OpenImageIO picks the format from it), then renames it.
template <typename Write>
Result<void> writeThroughTemporary(const std::filesystem::path& path, Write write) {
  const Result<const ImageCodec*> codec = imageCodec();
  if (!codec) return codec.error();
  std::filesystem::path temporary = path;
  temporary.replace_extension(".partial" + path.extension().string());
  const auto fail = [&](const std::string& what) {
    std::error_code ignored;
    std::filesystem::remove(temporary, ignored);
    return makeError(ErrorCode::IoError, path.string() + ": " + what);
  };
  const Result<void> written = write(**codec, temporary);
  if (!written) return fail(written.error().message);
  std::error_code ec;
  std::filesystem::rename(temporary, path, ec);
  if (ec) return fail("rename failed (" + ec.message() + ")");
  return {};
}

}  // namespace

Result<void> writeFrameImage(const std::filesystem::path& path, const gpu::RgbaImage& image) {
  return writeThroughTemporary(path, [&](const ImageCodec& codec, const std::filesystem::path& to) {
    return codec.write(to, pixelsOf(image), 3, isExrPath(path));
  });
}

Result<void> writeFrameRadiance(const std::filesystem::path& path, std::uint32_t width,
                                std::uint32_t height, const std::vector<float>& radiance,
                                float exposure) {
  if (radiance.size() != std::size_t{3} * width * height) {
    return makeError(ErrorCode::InvalidArgument, path.string() + ": the radiance holds " +
                                                     std::to_string(radiance.size()) +
                                                     " values, not 3 × " + std::to_string(width) +
                                                     " × " + std::to_string(height));
  }
  return writeThroughTemporary(path, [&](const ImageCodec& codec, const std::filesystem::path& to) {
    return codec.writeLinear(to, LinearRgbPixels{radiance.data(), width, height}, "pbdam:exposure",
                             exposure);
  });
}

Result<std::vector<unsigned char>> encodeFrameImage(const gpu::RgbaImage& image,
                                                    FrameEncoding encoding, int jpegQuality) {
  const Result<const ImageCodec*> codec = imageCodec();
  if (!codec) return codec.error();
  return (*codec)->encode(pixelsOf(image), encoding == FrameEncoding::Png ? "png" : "jpg", 3,
                          jpegQuality);
}

Result<std::vector<unsigned char>> encodeRgbaPng(const gpu::RgbaImage& image) {
  const Result<const ImageCodec*> codec = imageCodec();
  if (!codec) return codec.error();
  return (*codec)->encode(pixelsOf(image), "png", 4, 90);
}

}  // namespace pbdam::tools
