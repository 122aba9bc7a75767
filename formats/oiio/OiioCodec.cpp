// The OpenImageIO module (ImageCodec.h): the only code that includes OpenImageIO, built as
// libpbdam_oiio.so and loaded by imageCodec() on first use.
#include <OpenImageIO/filesystem.h>
#include <OpenImageIO/imagebuf.h>
#include <OpenImageIO/imagebufalgo.h>
#include <OpenImageIO/imageio.h>

#include <algorithm>
#include <array>

#include "pbdam/formats/ImageCodec.h"

namespace pbdam::formats {
namespace {

Result<Pixels8> read(const std::filesystem::path& path) {
  auto input = OIIO::ImageInput::open(path.string());
  if (!input) {
    return makeError(ErrorCode::UnsupportedFormat,
                     "not an image OpenImageIO can read (" + OIIO::geterror() + ")");
  }
  const OIIO::ImageSpec& spec = input->spec();
  if (spec.width < 1 || spec.height < 1 || spec.nchannels < 1 || spec.depth > 1) {
    return makeError(ErrorCode::UnsupportedFormat,
                     "unsupported image layout (" + std::to_string(spec.width) + "x" +
                         std::to_string(spec.height) + ", " + std::to_string(spec.nchannels) +
                         " channels)");
  }
  Pixels8 pixels;
  pixels.width = spec.width;
  pixels.height = spec.height;
  pixels.channels = std::min(spec.nchannels, 4);
  pixels.bytes.resize(static_cast<std::size_t>(pixels.width * pixels.height * pixels.channels));
  // Decoders such as libjpeg report a truncated file as a warning and fill the rest: any
  // message recorded during the read makes the image corrupt.
  const bool decoded =
      input->read_image(0, 0, 0, pixels.channels, OIIO::TypeDesc::UINT8, pixels.bytes.data());
  if (!decoded || input->has_error()) {
    return makeError(ErrorCode::CorruptData,
                     "cannot decode the pixels (" + input->geterror() + ")");
  }
  input->close();
  return pixels;
}

/// Opens `out` on `name` with `spec` (the channels it keeps of `image`), writes and closes it; the
/// error's message is what failed and OpenImageIO's reason.
Result<void> writeTo(OIIO::ImageOutput& out, const std::string& name, RgbaPixels image,
                     const OIIO::ImageSpec& spec, ErrorCode code) {
  if (!out.open(name, spec)) {
    return makeError(code, "cannot create (" + out.geterror() + ")");
  }
  // RGBA in memory: a 4-byte pixel stride whatever the file keeps.
  const bool written =
      out.write_image(OIIO::TypeDesc::UINT8, image.rgba, 4, OIIO::stride_t{4} * image.width);
  const bool closed = out.close();
  if (!written || !closed) return makeError(code, "write failed (" + out.geterror() + ")");
  return {};
}

Result<void> write(const std::filesystem::path& file, RgbaPixels image, int channels,
                   bool halfFloat) {
  auto out = OIIO::ImageOutput::create(file.string());
  if (!out) {
    return makeError(ErrorCode::IoError,
                     "cannot write this image format (" + OIIO::geterror() + ")");
  }
  OIIO::ImageSpec spec(static_cast<int>(image.width), static_cast<int>(image.height), channels,
                       halfFloat ? OIIO::TypeDesc::HALF : OIIO::TypeDesc::UINT8);
  if (!halfFloat) spec.attribute("png:compressionLevel", 1);
  return writeTo(*out, file.string(), image, spec, ErrorCode::IoError);
}

Result<void> writeLinear(const std::filesystem::path& file, LinearRgbPixels image,
                         const std::string& extraName, float extraValue) {
  auto out = OIIO::ImageOutput::create(file.string());
  if (!out) {
    return makeError(ErrorCode::IoError,
                     "cannot write this image format (" + OIIO::geterror() + ")");
  }
  OIIO::ImageSpec spec(static_cast<int>(image.width), static_cast<int>(image.height), 3,
                       OIIO::TypeDesc::HALF);
  if (!extraName.empty()) spec.attribute(extraName, extraValue);
  if (!out->open(file.string(), spec)) {
    return makeError(ErrorCode::IoError, "cannot create (" + out->geterror() + ")");
  }
  const bool written = out->write_image(OIIO::TypeDesc::FLOAT, image.rgb);
  const bool closed = out->close();
  if (!written || !closed) {
    return makeError(ErrorCode::IoError, "write failed (" + out->geterror() + ")");
  }
  return {};
}

Result<std::vector<unsigned char>> encode(RgbaPixels image, const std::string& format, int channels,
                                          int jpegQuality) {
  std::vector<unsigned char> bytes;
  OIIO::Filesystem::IOVecOutput proxy(bytes);
  // The name only picks the format; nothing touches the filesystem.
  const std::string name = "frame." + format;
  auto out = OIIO::ImageOutput::create(name, &proxy);
  if (!out) {
    return makeError(ErrorCode::Internal, "no " + name + " encoder (" + OIIO::geterror() + ")");
  }
  OIIO::ImageSpec spec(static_cast<int>(image.width), static_cast<int>(image.height), channels,
                       OIIO::TypeDesc::UINT8);
  if (format == "png") {
    spec.attribute("png:compressionLevel", 1);
  } else {
    spec.attribute("CompressionQuality", std::clamp(jpegQuality, 1, 100));
  }
  const Result<void> written = writeTo(*out, name, image, spec, ErrorCode::Internal);
  if (!written) {
    return makeError(ErrorCode::Internal, "encoding " + name + ": " + written.error().message);
  }
  return bytes;
}

Pixels8 drawText(const std::vector<std::string>& lines, const std::string& fontFile,
                 std::uint32_t maxWidth, int fontPixels) {
  Pixels8 panel;
  if (lines.empty() || maxWidth == 0) return panel;
  const int lineHeight = fontPixels + fontPixels / 4 + 1;
  const int margin = fontPixels / 2 + 2;
  int widest = 0;
  for (const std::string& line : lines) {
    const OIIO::ROI size = OIIO::ImageBufAlgo::text_size(line, fontPixels, fontFile);
    if (size.defined()) widest = std::max(widest, size.width());
  }
  const int width = std::min(static_cast<int>(maxWidth), widest + 2 * margin);
  const int height = static_cast<int>(lines.size()) * lineHeight + 2 * margin - fontPixels / 4;
  OIIO::ImageBuf buffer(OIIO::ImageSpec(width, height, 4, OIIO::TypeDesc::UINT8));
  const std::array<float, 4> background = {0.04f, 0.05f, 0.07f, 1.0f};
  const std::array<float, 4> ink = {0.92f, 0.95f, 0.90f, 1.0f};
  OIIO::ImageBufAlgo::fill(buffer, background);
  for (std::size_t i = 0; i < lines.size(); ++i) {
    const int baseline = margin + fontPixels + static_cast<int>(i) * lineHeight - 2;
    // A line the font cannot draw is left out; the panel stays.
    (void)OIIO::ImageBufAlgo::render_text(buffer, margin, baseline, lines[i], fontPixels, fontFile,
                                          ink);
  }
  panel.width = width;
  panel.height = height;
  panel.channels = 4;
  panel.bytes.resize(static_cast<std::size_t>(width) * static_cast<std::size_t>(height) * 4);
  buffer.get_pixels(OIIO::ROI::All(), OIIO::TypeDesc::UINT8, panel.bytes.data());
  return panel;
}

constexpr ImageCodec kCodec{&read, &write, &encode, &writeLinear, &drawText};

}  // namespace
}  // namespace pbdam::formats

/// The entry point imageCodec() looks up.
extern "C" __attribute__((visibility("default"))) const pbdam::formats::ImageCodec*
pbdam_oiio_codec() {
  return &pbdam::formats::kCodec;
}
