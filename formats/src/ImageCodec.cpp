// Loading the OpenImageIO module (ImageCodec.h).
#include "pbdam/formats/ImageCodec.h"

#include <dlfcn.h>

#include "pbdam/formats/Module.h"

namespace pbdam::formats {

Result<const ImageCodec*> imageCodec() {
  static const Result<const ImageCodec*> codec = []() -> Result<const ImageCodec*> {
    const Result<void*> module = openModule("libpbdam_oiio.so", {}, RTLD_NOW | RTLD_LOCAL);
    if (!module) {
      return makeError(ErrorCode::Internal, "no image codec: " + module.error().message);
    }
    using Codec = const ImageCodec* (*)();
    // NOLINTNEXTLINE(cppcoreguidelines-pro-type-reinterpret-cast): dlsym gives an object pointer
    const auto entry = reinterpret_cast<Codec>(::dlsym(*module, "pbdam_oiio_codec"));
    if (entry == nullptr) {
      return makeError(ErrorCode::Internal,
                       "no image codec: libpbdam_oiio.so lacks its entry point");
    }
    return entry();
  }();
  return codec;
}

}  // namespace pbdam::formats
