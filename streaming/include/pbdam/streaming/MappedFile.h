// MappedFile: streaming's name for a read-only whole-file mapping, which formats' MemoryMapping
// owns (MemoryMapping.h: open, bytes, madvise hints for prefetch, mincore residency). Face
// files are read only through mappings on the render path (docs/architecture.md "Streaming").
#pragma once

#include "pbdam/formats/MemoryMapping.h"

namespace pbdam::streaming {

/// A read-only file mapping, made with MappedFile::open (MemoryMapping::open).
using MappedFile = formats::MemoryMapping;

}  // namespace pbdam::streaming
