// Loading pbdam's own shared modules with dlopen (libpbdam_oiio.so, libpbdam_mpi.so): code whose
// libraries only some processes need, loaded by those. A module sits beside the running
// executable (pbdam, or a copy of it with its libraries); the path where the build wrote it is
// the fallback (test executables live elsewhere in the build tree).
// Thread-safety: safe from any thread (dlopen's own locking).
#pragma once

#include <filesystem>
#include <string>

#include "pbdam/formats/Result.h"

namespace pbdam::formats {

/// The dlopen handle of `fileName` beside /proc/self/exe, else of `buildPath` (skipped when
/// empty), opened with dlopen `flags`; never closed. NotFound naming every place tried and why
/// it failed (missing, or dlopen's message).
Result<void*> openModule(const std::string& fileName, const std::filesystem::path& buildPath,
                         int flags);

}  // namespace pbdam::formats
