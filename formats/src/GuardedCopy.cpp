// Guarded copies out of file mappings (GuardedCopy.h): a SIGBUS/SIGSEGV inside the copy becomes
// an error; any other fault goes to the handler that was installed before ours.
#include "pbdam/formats/GuardedCopy.h"

#include <setjmp.h>
#include <signal.h>
#include <ucontext.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <cstring>
#include <mutex>
#include <string>

#include "pbdam/formats/Checksum.h"

namespace pbdam::formats {
namespace {

/// The copy a thread is guarding now. Trivial and zero-initialised, so that the signal handler
/// may read it without running a constructor.
struct Guard {
  sigjmp_buf* jump;        ///< set only while a copy runs
  const std::byte* begin;  ///< the source range of that copy
  const std::byte* end;
  const std::byte* faultAddress;
  int faultSignal;
};
thread_local Guard tGuard{};

std::array<struct sigaction, 2> gPrevious{};  // SIGBUS, SIGSEGV; written once, before install
std::once_flag gInstalled;

/// Live mappings for reportUnreadableMappingsAndExit: a slot is claimed with a compare-exchange
/// on its state, filled, then published; the handler reads only published slots, without locks.
/// A slot freed and reused while a fault is reported can name the wrong file in that report; the
/// process ends either way.
constexpr int kSlotFree = 0, kSlotWriting = 1, kSlotLive = 2;
struct MappedRange {
  std::atomic<int> state{kSlotFree};
  const std::byte* begin = nullptr;
  std::size_t bytes = 0;
  std::array<char, 240> file{};
};
constexpr int kMappedRangeSlots = 256;
std::array<MappedRange, kMappedRangeSlots> gRanges;
std::atomic<int> gReportExitCode{-1};  ///< -1: no report, faults go to the previous handler

/// write(2) of a whole string, from the signal handler.
void writeAll(const char* text, std::size_t length) noexcept {
  while (length > 0) {
    const ssize_t n = ::write(STDERR_FILENO, text, length);
    if (n <= 0) return;
    text += n;
    length -= static_cast<std::size_t>(n);
  }
}

void writeText(const char* text) noexcept { writeAll(text, std::strlen(text)); }

void writeNumber(std::uint64_t value) noexcept {
  std::array<char, 24> digits{};
  std::size_t at = digits.size();
  do {
    digits[--at] = static_cast<char>('0' + value % 10);
    value /= 10;
  } while (value != 0);
  writeAll(digits.data() + at, digits.size() - at);
}

/// Reports a fault in a registered mapping and ends the process; returns when the address is in
/// none of them (or reports are off).
void reportIfMapped(int signalNumber, const std::byte* address) noexcept {
  const int exitCode = gReportExitCode.load(std::memory_order_acquire);
  if (exitCode < 0) return;
  for (const MappedRange& range : gRanges) {
    if (range.state.load(std::memory_order_acquire) != kSlotLive) continue;
    const std::byte* begin = range.begin;
    if (address < begin || address >= begin + range.bytes) continue;
    writeText("pbdam: ");
    writeText(range.file.data());
    writeText(": offset ");
    writeNumber(static_cast<std::uint64_t>(address - begin));
    writeText(signalNumber == SIGBUS
                  ? " became unreadable (SIGBUS: the file was truncated while in use, or its "
                    "disk failed)\n"
                  : " became unreadable (SIGSEGV)\n");
    ::_exit(exitCode);
  }
}

const struct sigaction& previousFor(int signalNumber) noexcept {
  return gPrevious[signalNumber == SIGBUS ? 0 : 1];
}

/// Hands a fault that no guarded copy expects to the handler installed before ours. For the
/// default action (or "ignore", which cannot apply to a real fault) the default is restored and
/// the handler returns: the faulting instruction runs again and the process dies of the signal
/// as it would have without us (core dump included); a signal sent by kill() is raised again.
void chainFault(int signalNumber, siginfo_t* info, void* context) noexcept {
  const struct sigaction& previous = previousFor(signalNumber);
  if ((previous.sa_flags & SA_SIGINFO) != 0) {
    if (previous.sa_sigaction != nullptr) previous.sa_sigaction(signalNumber, info, context);
    return;
  }
  if (previous.sa_handler != SIG_DFL && previous.sa_handler != SIG_IGN) {
    previous.sa_handler(signalNumber);
    return;
  }
  struct sigaction fallback {};
  fallback.sa_handler = SIG_DFL;
  sigemptyset(&fallback.sa_mask);
  ::sigaction(signalNumber, &fallback, nullptr);
  if (info->si_code <= 0) ::raise(signalNumber);  // sent, not a fault: it would not recur
}

void onFault(int signalNumber, siginfo_t* info, void* context) noexcept {
  Guard& guard = tGuard;
  const auto* address = static_cast<const std::byte*>(info->si_addr);
  if (guard.jump != nullptr && info->si_code > 0 && address >= guard.begin && address < guard.end) {
    sigjmp_buf* jump = guard.jump;
    guard.jump = nullptr;
    guard.faultAddress = address;
    guard.faultSignal = signalNumber;
    // The jump skips the sigreturn that would restore the faulting thread's signal mask. With
    // SA_NODEFER and an empty sa_mask the handler blocks nothing, but a runtime that wraps the
    // handlers (ThreadSanitizer installs its own with every signal blocked and calls ours from
    // it) leaves SIGBUS blocked after the jump, and the next fault would kill the process. The
    // mask of the interrupted code is in the context; putting it back costs a system call on
    // the fault path only.
    if (context != nullptr) {
      ::pthread_sigmask(SIG_SETMASK, &static_cast<const ucontext_t*>(context)->uc_sigmask, nullptr);
    }
    siglongjmp(*jump, 1);  // back into guardedCopy's frame, which owns nothing
  }
  if (info->si_code > 0) reportIfMapped(signalNumber, address);
  chainFault(signalNumber, info, context);
}

void install() noexcept {
  struct sigaction action {};
  action.sa_sigaction = onFault;
  // SA_NODEFER: the signal is not blocked while the handler runs, so the jump out of it needs
  // no sigprocmask to unblock it again (sigsetjmp(…, 0) saves no mask: no system call per copy).
  action.sa_flags = SA_SIGINFO | SA_NODEFER | SA_ONSTACK;
  sigemptyset(&action.sa_mask);
  ::sigaction(SIGBUS, &action, &gPrevious[0]);
  ::sigaction(SIGSEGV, &action, &gPrevious[1]);
}

/// The copy itself: a leaf whose frame holds nothing that needs unwinding, so a jump back into
/// it from the handler skips no destructor and leaves no lock held.
[[gnu::noinline]] bool copyOrFault(std::byte* destination, const std::byte* source,
                                   std::size_t bytes) noexcept {
  Guard& guard = tGuard;
  sigjmp_buf jump;
  if (sigsetjmp(jump, 0) != 0) return false;  // the handler cleared guard.jump
  guard.begin = source;
  guard.end = source + bytes;
  std::atomic_signal_fence(std::memory_order_seq_cst);
  guard.jump = &jump;
  std::atomic_signal_fence(std::memory_order_seq_cst);
  std::memcpy(destination, source, bytes);
  std::atomic_signal_fence(std::memory_order_seq_cst);
  guard.jump = nullptr;
  return true;
}

Error unreadable(std::string_view file, std::uint64_t offset, std::size_t bytes,
                 std::uint64_t faultOffset, int signalNumber) {
  return makeError(ErrorCode::CorruptData,
                   std::string(file) + ": cannot read " + std::to_string(bytes) +
                       " bytes at offset " + std::to_string(offset) + ": offset " +
                       std::to_string(faultOffset) + " is unreadable (" +
                       (signalNumber == SIGBUS ? "SIGBUS" : "SIGSEGV") +
                       ": the file was truncated under the mapping, or its disk failed)");
}

}  // namespace

void installMappedReadGuard() noexcept { std::call_once(gInstalled, install); }

void reportUnreadableMappingsAndExit(int exitCode) noexcept {
  installMappedReadGuard();
  gReportExitCode.store(exitCode, std::memory_order_release);
}

int registerMappedRange(const std::byte* begin, std::size_t bytes, std::string_view file) noexcept {
  if (begin == nullptr || bytes == 0) return -1;
  for (int slot = 0; slot < kMappedRangeSlots; ++slot) {
    MappedRange& range = gRanges[static_cast<std::size_t>(slot)];
    int expected = kSlotFree;
    if (!range.state.compare_exchange_strong(expected, kSlotWriting, std::memory_order_acq_rel)) {
      continue;
    }
    range.begin = begin;
    range.bytes = bytes;
    const std::size_t n = std::min(file.size(), range.file.size() - 1);
    std::memcpy(range.file.data(), file.data(), n);
    range.file[n] = '\0';
    range.state.store(kSlotLive, std::memory_order_release);  // the handler may read it now
    return slot;
  }
  return -1;
}

void unregisterMappedRange(int slot) noexcept {
  if (slot < 0 || slot >= kMappedRangeSlots) return;
  gRanges[static_cast<std::size_t>(slot)].state.store(kSlotFree, std::memory_order_release);
}

std::optional<CopyFault> guardedCopy(std::byte* destination, const std::byte* source,
                                     std::size_t bytes) noexcept {
  if (bytes == 0) return std::nullopt;
  installMappedReadGuard();
  if (copyOrFault(destination, source, bytes)) return std::nullopt;
  const Guard& guard = tGuard;
  return CopyFault{static_cast<std::size_t>(guard.faultAddress - source), guard.faultSignal};
}

Result<void> readMapped(std::span<const std::byte> mapped, std::uint64_t offset,
                        std::span<std::byte> out, std::string_view file) {
  if (offset > mapped.size() || out.size() > mapped.size() - offset) {
    return makeError(ErrorCode::CorruptData, std::string(file) + ": " + std::to_string(out.size()) +
                                                 " bytes at offset " + std::to_string(offset) +
                                                 " lie outside its " +
                                                 std::to_string(mapped.size()) + " bytes");
  }
  if (const auto fault = guardedCopy(out.data(), mapped.data() + offset, out.size())) {
    return unreadable(file, offset, out.size(), offset + fault->offset, fault->signalNumber);
  }
  return {};
}

Result<std::uint32_t> crc32Mapped(std::span<const std::byte> mapped, std::uint64_t offset,
                                  std::uint64_t length, std::string_view file, std::uint32_t crc) {
  if (offset > mapped.size() || length > mapped.size() - offset) {
    return makeError(ErrorCode::CorruptData, std::string(file) + ": " + std::to_string(length) +
                                                 " bytes at offset " + std::to_string(offset) +
                                                 " lie outside its " +
                                                 std::to_string(mapped.size()) + " bytes");
  }
  constexpr std::size_t kPieceBytes = std::size_t{64} << 10;
  std::array<std::byte, kPieceBytes> piece;  // NOLINT(cppcoreguidelines-pro-type-member-init)
  for (std::uint64_t at = offset; at < offset + length; at += kPieceBytes) {
    const auto n =
        static_cast<std::size_t>(std::min<std::uint64_t>(kPieceBytes, offset + length - at));
    if (auto r = readMapped(mapped, at, std::span(piece).first(n), file); !r) {
      return std::move(r).error();
    }
    crc = crc32(std::span<const std::byte>(piece).first(n), crc);
  }
  return crc;
}

}  // namespace pbdam::formats
