// pbdam_headless: what embedding pbdam takes — open a dataset as a gpu::Terrain, update it with
// one camera (the frame's cut), draw it offscreen and write a PNG; `pbdam render DIR --camera ...
// --width W --height H` gives the same bytes (docs/embedding.md).
//   pbdam_headless DATASET LAT,LON,ALT[,HEADING,PITCH,ROLL] OUT.png [WIDTH HEIGHT]
#include <charconv>
#include <cstdint>
#include <cstdio>
#include <exception>
#include <string_view>

#include "pbdam/formats/ImageCodec.h"
#include "pbdam/gpu/Terrain.h"
#include "pbdam/gpu/VulkanContext.h"
#include "pbdam/runtime/Camera.h"

namespace {

int fail(const pbdam::formats::Error& error) {
  std::fprintf(stderr, "pbdam_headless: %s\n", error.message.c_str());
  return 1;
}

bool parsePixels(std::string_view text, std::uint32_t& pixels) {
  const auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), pixels);
  return ec == std::errc() && end == text.data() + text.size();
}

int run(int argc, char** argv) {
  pbdam::runtime::Viewport viewport;  // 1280 x 720, 60° vertical field of view
  if ((argc != 4 && argc != 6) || (argc == 6 && (!parsePixels(argv[4], viewport.width) ||
                                                 !parsePixels(argv[5], viewport.height)))) {
    std::fprintf(stderr,
                 "usage: pbdam_headless DATASET LAT,LON,ALT[,HEADING,PITCH,ROLL] OUT.png "
                 "[WIDTH HEIGHT]\n");
    return 2;
  }
  if (auto valid = pbdam::runtime::validateViewport(viewport); !valid) return fail(valid.error());
  // The device: PBDAM_DEVICE if set (e.g. "lavapipe"), else the machine's best.
  auto context = pbdam::gpu::VulkanContext::create();
  if (!context) return fail(context.error());
  pbdam::gpu::TerrainOptions options;  // exact mode, 3 px tolerance, a 256 MiB GPU cache
  options.viewport = viewport;
  auto terrain = pbdam::gpu::Terrain::open(*context, argv[1], options);
  if (!terrain) return fail(terrain.error());
  const pbdam::runtime::Planet& planet = (*terrain)->view().planet();
  auto pose = pbdam::runtime::parseCameraPose(argv[2]);
  if (!pose) return fail(pose.error());
  if (auto valid = pbdam::runtime::validateCameraPose(*pose, planet); !valid) {
    return fail(valid.error());
  }

  const auto camera = pbdam::runtime::Camera::fromPose(planet, *pose, viewport);
  if (auto cut = (*terrain)->update(camera); !cut) return fail(cut.error());
  if (auto submitted = (*terrain)->submit(); !submitted) return fail(submitted.error());
  auto frame = (*terrain)->collect();  // RGBA8, top row first
  if (!frame) return fail(frame.error());

  auto codec = pbdam::formats::imageCodec();
  if (!codec) return fail(codec.error());
  const pbdam::formats::RgbaPixels pixels{frame->image.rgba.data(), frame->image.widthPixels,
                                          frame->image.heightPixels};
  if (auto written = (*codec)->write(argv[3], pixels, 3, false); !written) {
    return fail(written.error());
  }
  std::printf("%s: %u x %u on %s: %llu patches, %llu triangles, %llu tiles; frame %.1f ms\n",
              argv[3], viewport.width, viewport.height, context->deviceInfo().name.c_str(),
              static_cast<unsigned long long>(frame->stats.patches),
              static_cast<unsigned long long>(frame->stats.triangles),
              static_cast<unsigned long long>(frame->stats.tiles), frame->stats.frameMs);
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  // pbdam reports bad input as results; what it throws is a bug or exhausted memory.
  try {
    return run(argc, argv);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "pbdam_headless: %s\n", e.what());
    return 1;
  }
}
