// Frame export through OpenImageIO (FrameImage.h).
#include "FrameImage.h"

#include <OpenImageIO/filesystem.h>
#include <OpenImageIO/imageio.h>

#include <algorithm>
#include <cctype>
#include <string>
#include <system_error>

using namespace pbdam::formats;

namespace pbdam::tools {

bool isExrPath(const std::filesystem::path& path) {
  std::string ext = path.extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return ext == ".exr";
}

Result<void> writeFrameImage(const std::filesystem::path& path, const gpu::RgbaImage& image) {
  const bool exr = isExrPath(path);
  // The temporary keeps the extension: OpenImageIO picks the format from it.
  std::filesystem::path temporary = path;
  temporary.replace_extension(".partial" + path.extension().string());
  auto out = OIIO::ImageOutput::create(temporary.string());
  if (!out) {
    return makeError(ErrorCode::IoError,
                     path.string() + ": cannot write this image format (" + OIIO::geterror() + ")");
  }
  OIIO::ImageSpec spec(static_cast<int>(image.widthPixels), static_cast<int>(image.heightPixels), 3,
                       exr ? OIIO::TypeDesc::HALF : OIIO::TypeDesc::UINT8);
  if (!exr) spec.attribute("png:compressionLevel", 1);
  const auto fail = [&](const std::string& what) {
    std::error_code ignored;
    std::filesystem::remove(temporary, ignored);
    return makeError(ErrorCode::IoError, path.string() + ": " + what);
  };
  if (!out->open(temporary.string(), spec)) return fail("cannot create (" + out->geterror() + ")");
  // RGBA in memory, RGB in the file: a 4-byte pixel stride.
  const bool written = out->write_image(OIIO::TypeDesc::UINT8, image.rgba.data(), 4,
                                        OIIO::stride_t{4} * image.widthPixels);
  const bool closed = out->close();
  if (!written || !closed) return fail("write failed (" + out->geterror() + ")");
  std::error_code ec;
  std::filesystem::rename(temporary, path, ec);
  if (ec) return fail("rename failed (" + ec.message() + ")");
  return {};
}

namespace {

/// `channels` 3: RGB; 4: RGBA (PNG only).
Result<std::vector<unsigned char>> encode(const gpu::RgbaImage& image, FrameEncoding encoding,
                                          int jpegQuality, int channels) {
  std::vector<unsigned char> bytes;
  OIIO::Filesystem::IOVecOutput proxy(bytes);
  // The name only picks the format; nothing touches the filesystem.
  const char* name = encoding == FrameEncoding::Png ? "frame.png" : "frame.jpg";
  auto out = OIIO::ImageOutput::create(name, &proxy);
  if (!out) {
    return makeError(ErrorCode::Internal,
                     std::string("no ") + name + " encoder (" + OIIO::geterror() + ")");
  }
  OIIO::ImageSpec spec(static_cast<int>(image.widthPixels), static_cast<int>(image.heightPixels),
                       channels, OIIO::TypeDesc::UINT8);
  if (encoding == FrameEncoding::Png) {
    spec.attribute("png:compressionLevel", 1);
  } else {
    spec.attribute("CompressionQuality", std::clamp(jpegQuality, 1, 100));
  }
  if (!out->open(name, spec)) {
    return makeError(ErrorCode::Internal,
                     std::string("cannot encode ") + name + " (" + out->geterror() + ")");
  }
  const bool written = out->write_image(OIIO::TypeDesc::UINT8, image.rgba.data(), 4,
                                        OIIO::stride_t{4} * image.widthPixels);
  const bool closed = out->close();
  if (!written || !closed) {
    return makeError(ErrorCode::Internal,
                     std::string("encoding ") + name + " failed (" + out->geterror() + ")");
  }
  return bytes;
}

}  // namespace

Result<std::vector<unsigned char>> encodeFrameImage(const gpu::RgbaImage& image,
                                                    FrameEncoding encoding, int jpegQuality) {
  return encode(image, encoding, jpegQuality, 3);
}

Result<std::vector<unsigned char>> encodeRgbaPng(const gpu::RgbaImage& image) {
  return encode(image, FrameEncoding::Png, 90, 4);
}

}  // namespace pbdam::tools
