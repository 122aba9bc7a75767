// Sanitizer support for every executable that links pbdam_gpu. Vulkan drivers and layers
// (lavapipe, its LLVM JIT, the Khronos validation layer, Mesa's device-select layer) keep
// process-lifetime allocations that LSan reports at exit, and the loader dlclose()s them first,
// so LSan could not even name them ("<unknown module>") and TSan aborts when a library named in
// a called_from_lib suppression (tests/sanitizers/tsan.supp) is unloaded. Under ASan and TSan we
// pin those libraries (RTLD_NODELETE); under ASan we also suppress leaks whose stacks pass
// through them (and through fontconfig and libltdl, which PLplot's cairo driver uses for the
// bench report). Nothing of pbdam's own is suppressed: a leak or race of ours still fails.
#if defined(__SANITIZE_ADDRESS__) || defined(__SANITIZE_THREAD__)

#include <dlfcn.h>

namespace {

// Libraries named in the Debian 12 ICD and layer manifests (/usr/share/vulkan/*/*.json).
constexpr const char* kVulkanLibraries[] = {
    "libvulkan_lvp.so",   "libVkLayer_khronos_validation.so", "libVkLayer_MESA_device_select.so",
    "libvulkan_intel.so", "libvulkan_intel_hasvk.so",         "libvulkan_radeon.so",
};

struct PinVulkanLibraries {
  PinVulkanLibraries() {
    for (const char* name : kVulkanLibraries) {
      // A missing library is fine (the test then reports the missing driver itself). The
      // handle is deliberately never closed.
      (void)dlopen(name, RTLD_NOW | RTLD_LOCAL | RTLD_NODELETE);
    }
  }
};
const PinVulkanLibraries pinVulkanLibraries;

}  // namespace

#endif  // __SANITIZE_ADDRESS__ || __SANITIZE_THREAD__

#if defined(__SANITIZE_THREAD__)

#include <tbb/global_control.h>

namespace {

// Debian's libtbb is not instrumented, so TSan cannot see the happens-before edges of TBB's
// task handoffs and reports every parallel_for the renderer runs (patch decoding) as a race in
// TBB's own partitioner. Under TSan, TBB work therefore runs on the calling thread (no TBB
// workers); pbdam's own threads — the prefetcher, the no-stall loader, server workers — are
// still checked. The TBB-parallel paths are covered by byte-identical outputs across thread
// counts in the release and ASan runs.
const tbb::global_control serialTbbUnderTsan(tbb::global_control::max_allowed_parallelism, 1);

}  // namespace

#endif  // __SANITIZE_THREAD__

#if defined(__SANITIZE_ADDRESS__)

// LSan reads these suppressions at start-up, in addition to any LSAN_OPTIONS suppressions.
extern "C" const char* __lsan_default_suppressions();  // NOLINT(bugprone-reserved-identifier)
extern "C" const char* __lsan_default_suppressions() {
  return "leak:libvulkan_lvp.so\n"
         "leak:libLLVM-15.so\n"
         "leak:libVkLayer_khronos_validation.so\n"
         "leak:libVkLayer_MESA_device_select.so\n"
         "leak:libvulkan_intel.so\n"
         "leak:libvulkan_intel_hasvk.so\n"
         "leak:libvulkan_radeon.so\n"
         // PLplot's cairo driver (pbdam bench reports): fontconfig's process-lifetime font
         // caches, and the driver module libltdl loads and never frees.
         "leak:libfontconfig.so\n"
         "leak:libltdl.so\n";
}

#endif  // __SANITIZE_ADDRESS__
