// Loading pbdam's own shared modules with dlopen (libpbdam_oiio.so, libpbdam_mpi.so): code whose
// libraries only some processes need, loaded by those. A module sits beside the running
// executable (pbdam, or a copy of it with its libraries); else where a build path says, else where
// the dynamic linker finds it by name: the RUNPATH of the executable (or of a shared
// libpbdam_formats), LD_LIBRARY_PATH, the system's library directories. Executables that link
// pbdam_formats get a RUNPATH to the module's directory, in the build tree and from the installed
// package (docs/embedding.md).
// Thread-safety: safe from any thread (dlopen's own locking).
#pragma once

#include <filesystem>
#include <string>

#include "pbdam/formats/Result.h"

namespace pbdam::formats {

/// The dlopen handle of `fileName` beside /proc/self/exe, else of `buildPath` (skipped when
/// empty), else of `fileName` as the dynamic linker searches for it, opened with dlopen `flags`;
/// never closed. NotFound naming every place tried and why it failed (missing, or dlopen's
/// message).
Result<void*> openModule(const std::string& fileName, const std::filesystem::path& buildPath,
                         int flags);

}  // namespace pbdam::formats
