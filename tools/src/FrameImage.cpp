// Frame export through OpenImageIO (FrameImage.h).
#include "FrameImage.h"

#include <OpenImageIO/imageio.h>

#include <algorithm>
#include <cctype>
#include <string>
#include <system_error>

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

}  // namespace pbdam::tools
