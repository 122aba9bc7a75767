// Result<T>: a value or an Error (code + message naming the file/offset/field). Fallible loads
// and decodes return one instead of throwing; exceptions never cross module boundaries.
#pragma once

#include <cassert>
#include <string>
#include <utility>
#include <variant>

/// @namespace pbdam
/// The library: four layers, one namespace each, each using only the ones before it — formats →
/// runtime → streaming → gpu (docs/architecture.md "Modules").

/// The formats layer: the dataset's file formats (manifest, face files, patches, texture tiles,
/// void maps), DEM and image input, camera paths, checked file mappings and writes, and the
/// Result type every fallible call of every layer returns. No Vulkan, no threads of its own.
namespace pbdam::formats {

/// What went wrong, coarsely, so callers can map it to an exit code or an HTTP status.
enum class ErrorCode {
  InvalidArgument,    ///< a parameter is missing, NaN or out of range
  NotFound,           ///< a file or resource does not exist
  UnsupportedFormat,  ///< a format/driver/CRS that pbdam cannot handle
  CorruptData,        ///< bytes that do not decode: truncated, bad checksum, size mismatch
  IoError,            ///< the OS refused a read, write, map or rename
  NoSpace,            ///< a write found the disk full, the quota or the file-size limit reached
  DeviceError,        ///< Vulkan or another device API failed
  Internal,           ///< a broken invariant inside pbdam
};

/// Returns a short, stable name for `code` ("invalid-argument", "corrupt-data", ...).
const char* errorCodeName(ErrorCode code) noexcept;

/// An error: a code and a human-readable message that names what was wrong (file, offset,
/// field). Messages are single lines without a trailing period.
struct Error final {
  ErrorCode code = ErrorCode::Internal;  ///< the kind of failure
  std::string message;                   ///< what failed and where, one line
};

/// Either a T or an Error. Access the value only after checking ok(); doing otherwise is a
/// programming error and asserts.
template <typename T>
class [[nodiscard]] Result final {
 public:
  /// A success holding `value` (implicit, so that a function can `return value;`).
  Result(T value) : state_(std::in_place_index<0>, std::move(value)) {}  // NOLINT
  /// A failure holding `error` (implicit, so that a function can `return error;`).
  Result(Error error) : state_(std::in_place_index<1>, std::move(error)) {}  // NOLINT

  /// Whether it holds a value rather than an error.
  /// @{
  bool ok() const noexcept { return state_.index() == 0; }
  explicit operator bool() const noexcept { return ok(); }
  /// @}

  /// The value; it must hold one (ok()).
  /// @{
  T& value() & {
    assert(ok());
    return std::get<0>(state_);
  }
  const T& value() const& {
    assert(ok());
    return std::get<0>(state_);
  }
  T&& value() && {
    assert(ok());
    return std::get<0>(std::move(state_));
  }
  T* operator->() { return &value(); }
  const T* operator->() const { return &value(); }
  T& operator*() & { return value(); }
  const T& operator*() const& { return value(); }
  /// @}

  /// The error; it must hold one (not ok()).
  /// @{
  const Error& error() const& {
    assert(!ok());
    return std::get<1>(state_);
  }
  Error&& error() && {
    assert(!ok());
    return std::get<1>(std::move(state_));
  }
  /// @}

 private:
  std::variant<T, Error> state_;
};

/// Result for operations that produce nothing but can fail.
template <>
class [[nodiscard]] Result<void> final {
 public:
  /// A success.
  Result() = default;
  /// A failure holding `error` (implicit, so that a function can `return error;`).
  Result(Error error) : error_(std::move(error)), ok_(false) {}  // NOLINT
  /// Whether it succeeded.
  /// @{
  bool ok() const noexcept { return ok_; }
  explicit operator bool() const noexcept { return ok_; }
  /// @}
  /// The error; it must hold one (not ok()).
  /// @{
  const Error& error() const& {
    assert(!ok_);
    return error_;
  }
  Error&& error() && {
    assert(!ok_);
    return std::move(error_);
  }
  /// @}

 private:
  Error error_;
  bool ok_ = true;
};

/// Builds an Error; shorthand for `Error{code, std::move(message)}`.
inline Error makeError(ErrorCode code, std::string message) {
  return Error{code, std::move(message)};
}

/// Builds an InvalidArgument Error (a parameter, option or request that is missing, NaN or out
/// of range); shorthand for `makeError(ErrorCode::InvalidArgument, std::move(message))`.
inline Error invalidArgument(std::string message) {
  return makeError(ErrorCode::InvalidArgument, std::move(message));
}

}  // namespace pbdam::formats
