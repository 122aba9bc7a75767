// Names of error codes (Result.h).
#include "pbdam/formats/Result.h"

namespace pbdam::formats {

const char* errorCodeName(ErrorCode code) noexcept {
  switch (code) {
    case ErrorCode::InvalidArgument:
      return "invalid-argument";
    case ErrorCode::NotFound:
      return "not-found";
    case ErrorCode::UnsupportedFormat:
      return "unsupported-format";
    case ErrorCode::CorruptData:
      return "corrupt-data";
    case ErrorCode::IoError:
      return "io-error";
    case ErrorCode::NoSpace:
      return "no-space";
    case ErrorCode::DeviceError:
      return "device-error";
    case ErrorCode::Internal:
      return "internal";
  }
  return "unknown";
}

}  // namespace pbdam::formats
