// GuardedCopy: reading bytes of a file mapping without letting an unreadable page kill the
// process. A mapped page that cannot be read — the file was truncated under the mapping, or the
// disk returned an I/O error — raises SIGBUS (or SIGSEGV) at the instruction that touched it.
// guardedCopy() copies out of a mapping with that instruction inside a guard: a thread-local
// sigsetjmp around one memcpy in a leaf function that holds no locks and owns no resources, and
// a process-wide SIGBUS/SIGSEGV handler that jumps back when the fault lies in the range being
// copied and otherwise hands the signal to whatever handler was there before (so a fault
// anywhere else still crashes exactly as it did). Every read of a dataset byte goes through
// here (docs/architecture.md "Threads", docs/decisions.md "Unreadable mapped pages").
// Thread-safety: every function may be called from any thread.
#pragma once

#include <cstddef>
#include <cstdint>
#include <optional>
#include <span>
#include <string_view>

#include "pbdam/formats/Result.h"

namespace pbdam::formats {

/// Where a guarded copy stopped: the first unreadable byte, as an offset from the copy's source,
/// and the signal that reported it (SIGBUS or SIGSEGV).
struct CopyFault final {
  std::size_t offset = 0;  ///< bytes from the copy's source to the first unreadable one
  int signalNumber = 0;    ///< SIGBUS or SIGSEGV
};

/// Installs the fault handlers once per process (later calls do nothing); the previous
/// handlers are kept and called for every fault outside a guarded copy. guardedCopy() calls it;
/// MemoryMapping::open() calls it too, so the handlers are in place before any mapped byte can
/// be read.
void installMappedReadGuard() noexcept;

/// Copies `bytes` bytes from `source` to `destination` like memcpy, except that a SIGBUS or
/// SIGSEGV while reading [source, source + bytes) ends the copy and is returned instead of
/// killing the process; `destination` then holds an unspecified prefix. Returns nullopt when
/// every byte was copied. `destination` must be ordinary memory (a fault writing it is not
/// caught) and must not overlap the source. Costs a sigsetjmp (no system call) on top of the
/// memcpy.
std::optional<CopyFault> guardedCopy(std::byte* destination, const std::byte* source,
                                     std::size_t bytes) noexcept;

/// The fallback for code that reads a mapping in place rather than through guarded copies (the
/// builder's per-sample reads of its own scratch and checkpoint files, where a copy per sample
/// would cost more than the work): once a process calls this, a fault outside any guarded copy
/// whose address lies in a live read-only or writable file mapping (MemoryMapping registers
/// each) writes "pbdam: FILE: offset N became unreadable (SIGBUS: ...)" to stderr and ends the
/// process with `exitCode` (_exit: no destructors run, as with the crash it replaces). Faults
/// anywhere else are still handed to the previous handler. For command-line tools only — a
/// server must not die of one bad file; its reads all go through guarded copies. A negative
/// `exitCode` turns the report off again (faults outside guards crash as before).
void reportUnreadableMappingsAndExit(int exitCode) noexcept;

/// Registers `bytes` bytes at `begin`, a mapping of `file`, for the report above; returns a
/// slot to pass to unregisterMappedRange (or -1 when every slot is taken: such a range is not
/// reported); unregisterMappedRange frees the slot. MemoryMapping calls these; nobody else
/// needs to.
/// @{
int registerMappedRange(const std::byte* begin, std::size_t bytes, std::string_view file) noexcept;
void unregisterMappedRange(int slot) noexcept;
/// @}

/// Copies bytes [offset, offset + out.size()) of `mapped` (a whole file's mapping, or bytes in
/// memory) into `out` through guardedCopy. Errors, naming `file` and the offset: CorruptData
/// when the range lies outside `mapped` or a page of it cannot be read (the file was truncated
/// under the mapping, or its disk failed).
Result<void> readMapped(std::span<const std::byte> mapped, std::uint64_t offset,
                        std::span<std::byte> out, std::string_view file);

/// CRC-32 (formats/Checksum.h) of bytes [offset, offset + length) of `mapped`, read through
/// guardedCopy in 64 KiB pieces, continuing from `crc` (0 to start). Errors as readMapped.
Result<std::uint32_t> crc32Mapped(std::span<const std::byte> mapped, std::uint64_t offset,
                                  std::uint64_t length, std::string_view file,
                                  std::uint32_t crc = 0);

}  // namespace pbdam::formats
