// The P-BDAM build pipeline (Builder.h; docs/builder.md; paper 004 §5), one process or several
// (docs/builder.md "Distributed build"): every stage's independent work — lattice rows, the
// blocks (diamonds) of each bintree level with their error saturation, texture tiles — is split
// into contiguous ranges per rank and run with TBB inside each rank. Out of core: the lattice
// heights and bucketed source samples live in files every rank maps; each rank streams its nodes
// and its carry (what the next level needs) into its own checkpoint part files, batch by batch;
// the next level reads the children of its diamonds from those files. The ranks synchronise only
// between levels (a small all-gather of per-rank statistics); rank 0 records the checkpoint
// state and finally assembles the dataset from the part files through mappings.
#include "pbdam/builder/Builder.h"

#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <bit>
#include <chrono>
#include <cmath>
#include <condition_variable>
#include <csignal>
#include <cstdio>
#include <cstring>
#include <functional>
#include <limits>
#include <mutex>
#include <stop_token>
#include <thread>

#include "pbdam/builder/Checkpoint.h"
#include "pbdam/builder/Lattice.h"
#include "pbdam/builder/PatchBuilder.h"
#include "pbdam/builder/ResidentTrimmer.h"
#include "pbdam/builder/SampleGrid.h"
#include "pbdam/builder/TextureBuilder.h"
#include "pbdam/formats/Checksum.h"
#include "pbdam/formats/DatasetFormat.h"
#include "pbdam/formats/Image.h"
#include "pbdam/formats/Manifest.h"
#include "pbdam/formats/PatchCodec.h"
#include "pbdam/runtime/Planet.h"

namespace pbdam::builder {

std::string LocalCommunicator::hostName() const {
  char name[256] = {};
  if (::gethostname(name, sizeof name - 1) != 0) return "localhost";
  return name;
}

void LocalCommunicator::abortJob(int exitCode) { std::_Exit(exitCode); }

namespace {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

struct Sphere {
  glm::dvec3 center{0.0};
  double radius = 0.0;
};

/// The smallest sphere enclosing two spheres.
Sphere merge(const Sphere& a, const Sphere& b) {
  const double d = glm::length(b.center - a.center);
  if (d + b.radius <= a.radius) return a;
  if (d + a.radius <= b.radius) return b;
  const double r = 0.5 * (d + a.radius + b.radius);
  return Sphere{a.center + (b.center - a.center) * ((r - a.radius) / d), r};
}

/// Rounds a radius up to a float that still encloses (with a millimetre-scale margin).
float storedRadius(double r) {
  const double padded = r * (1.0 + 1e-6) + 1e-3;
  float f = static_cast<float>(padded);
  if (static_cast<double>(f) < padded) f = std::nextafter(f, std::numeric_limits<float>::max());
  return f;
}

float roundUpToFloat(double v) {
  float f = static_cast<float>(v);
  if (static_cast<double>(f) < v) f = std::nextafter(f, std::numeric_limits<float>::max());
  return f;
}

Error invalid(const std::string& what) { return makeError(ErrorCode::InvalidArgument, what); }

std::string hex32(std::uint32_t v) {
  char s[16];
  std::snprintf(s, sizeof s, "%08x", v);
  return s;
}

std::string exact(double v) {
  char s[40];
  std::snprintf(s, sizeof s, "%.17g", v);
  return s;
}

/// A node as its level produces it: the record (saturated), its blob, and what saturation
/// needs.
struct NodeOut {
  std::uint64_t id = 0;
  NodeRecord record;
  std::vector<std::byte> blob;
  double measuredError = 0.0;
  Sphere sphere;
};

/// The saturated error and sphere of a diamond (both its triangles store them).
struct Saturated {
  double error = 0.0;  // the stored float, as double
  Sphere sphere;       // centre, stored radius
};

/// Contiguous share [begin, end) of `count` items for `rank` of `ranks`.
std::pair<std::uint64_t, std::uint64_t> shareOf(std::uint64_t count, int rank, int ranks) {
  const auto r = static_cast<std::uint64_t>(rank);
  const auto n = static_cast<std::uint64_t>(ranks);
  return {count * r / n, count * (r + 1) / n};
}

/// A working patch in the carry: u32 point count, u8 width (2 when every coordinate and index
/// fits 16 bits — always for lattices up to 16384 cells and patches up to 65536 points — else
/// 4), the points' (x, y), u32 index count, the indices; each value in `width` bytes. Half the
/// bytes of plain 32-bit values: the carry of the first block level is most of the build's I/O
/// and disk.
void putPatch(ByteWriter& w, const WorkPatch& p) {
  bool narrow = p.points.size() <= 65536;
  for (const LatticeXY& q : p.points) {
    narrow = narrow && q.x >= 0 && q.x <= 65535 && q.y >= 0 && q.y <= 65535;
  }
  w.put(static_cast<std::uint32_t>(p.points.size()));
  w.put(static_cast<std::uint8_t>(narrow ? 2 : 4));
  if (narrow) {
    std::vector<std::uint16_t> values;
    values.reserve(2 * p.points.size());
    for (const LatticeXY& q : p.points) {
      values.push_back(static_cast<std::uint16_t>(q.x));
      values.push_back(static_cast<std::uint16_t>(q.y));
    }
    w.putBytes(std::as_bytes(std::span<const std::uint16_t>(values)));
    values.assign(p.indices.begin(), p.indices.end());  // < 65536: indices of the points
    w.put(static_cast<std::uint32_t>(values.size()));
    w.putBytes(std::as_bytes(std::span<const std::uint16_t>(values)));
    return;
  }
  for (const LatticeXY& q : p.points) {
    w.put(q.x);
    w.put(q.y);
  }
  w.put(static_cast<std::uint32_t>(p.indices.size()));
  w.putBytes(std::as_bytes(std::span<const std::uint32_t>(p.indices)));
}

WorkPatch getPatch(ByteReader& r) {
  WorkPatch p;
  const auto points = r.get<std::uint32_t>();
  const auto width = r.get<std::uint8_t>();
  if (r.failed() || (width != 2 && width != 4)) return p;
  const auto coordinates = r.take(std::size_t{points} * 2 * width);
  if (r.failed()) return p;
  p.points.resize(points);
  for (std::size_t k = 0; k < points; ++k) {
    if (width == 2) {
      std::array<std::uint16_t, 2> xy{};
      std::memcpy(xy.data(), coordinates.data() + 4 * k, 4);
      p.points[k] = LatticeXY(static_cast<std::int32_t>(xy[0]), static_cast<std::int32_t>(xy[1]));
    } else {
      std::memcpy(&p.points[k].x, coordinates.data() + 8 * k, 4);
      std::memcpy(&p.points[k].y, coordinates.data() + 8 * k + 4, 4);
    }
  }
  const auto indices = r.get<std::uint32_t>();
  const auto run = r.take(std::size_t{indices} * width);
  if (r.failed()) return p;
  p.indices.resize(indices);
  if (width == 4) {
    std::memcpy(p.indices.data(), run.data(), run.size());
  } else {
    for (std::size_t k = 0; k < indices; ++k) {
      std::uint16_t v = 0;
      std::memcpy(&v, run.data() + 2 * k, 2);
      p.indices[k] = v;
    }
  }
  return p;
}

/// One triangle's carry record: its diamond's saturated error and sphere, and its working patch
/// when the next level needs it (docs/builder.md "Checkpoints").
void putCarry(ByteWriter& w, const Saturated& s, const WorkPatch* patch) {
  w.put(static_cast<float>(s.error));
  w.put(s.sphere.center.x);
  w.put(s.sphere.center.y);
  w.put(s.sphere.center.z);
  w.put(static_cast<float>(s.sphere.radius));
  w.put(static_cast<std::uint8_t>(patch != nullptr ? 1 : 0));
  if (patch != nullptr) putPatch(w, *patch);
}

/// The carry of a finished level as the next level reads it: the level's part files mapped
/// read-only, each ending in an index (node id, record offset) sorted by node id, so a rank
/// finds the children of its own diamonds without holding the level. Thread-safe lookups.
class CarryReader final {
 public:
  Result<void> open(const Checkpoint& checkpoint, int level, std::uint32_t parts, bool verify) {
    parts_.clear();
    for (std::uint32_t part = 0; part < parts; ++part) {
      Part p;
      auto mapped = checkpoint.openFile(Checkpoint::Kind::Carry, level, part, p.payload, verify);
      if (!mapped) return std::move(mapped).error();
      const auto path = checkpoint.file(Checkpoint::Kind::Carry, level, part).string();
      if (p.payload.size() < 8) return makeError(ErrorCode::CorruptData, path + ": no index");
      std::memcpy(&p.count, p.payload.data() + p.payload.size() - 8, 8);
      if (p.count > (p.payload.size() - 8) / 16) {
        return makeError(ErrorCode::CorruptData, path + ": bad index");
      }
      p.index = p.payload.data() + p.payload.size() - 8 - 16 * p.count;
      p.file = std::move(mapped).value();
      parts_.push_back(std::move(p));
    }
    return {};
  }
  void close() { parts_.clear(); }
  void releaseResident() const noexcept {
    for (const Part& p : parts_) (void)p.file.releaseResident();
  }
  /// The saturated values of node `id`'s diamond and, with `patch`, its working patch; false
  /// when the carry does not hold the node (or its record is damaged).
  bool find(std::uint64_t id, Saturated& saturated, WorkPatch* patch) const {
    for (const Part& p : parts_) {
      std::uint64_t lo = 0;
      std::uint64_t hi = p.count;
      while (lo < hi) {
        const std::uint64_t mid = lo + (hi - lo) / 2;
        std::uint64_t key = 0;
        std::memcpy(&key, p.index + 16 * mid, 8);
        if (key < id) {
          lo = mid + 1;
        } else {
          hi = mid;
        }
      }
      if (lo == p.count) continue;
      std::uint64_t key = 0;
      std::uint64_t offset = 0;
      std::memcpy(&key, p.index + 16 * lo, 8);
      std::memcpy(&offset, p.index + 16 * lo + 8, 8);
      if (key != id || offset >= p.payload.size()) continue;
      ByteReader r(p.payload.subspan(static_cast<std::size_t>(offset)));
      saturated.error = static_cast<double>(r.get<float>());
      saturated.sphere.center.x = r.get<double>();
      saturated.sphere.center.y = r.get<double>();
      saturated.sphere.center.z = r.get<double>();
      saturated.sphere.radius = static_cast<double>(r.get<float>());
      const bool hasPatch = r.get<std::uint8_t>() != 0;
      if (patch != nullptr) {
        if (!hasPatch) return false;
        *patch = getPatch(r);
      }
      return !r.failed();
    }
    return false;
  }

 private:
  struct Part {
    MappedFile file;
    std::span<const std::byte> payload;
    const std::byte* index = nullptr;
    std::uint64_t count = 0;
  };
  std::vector<Part> parts_;
};

/// Collective: the first failure of any rank (lowest rank first) on every rank.
Result<void> agree(Communicator& comm, const Result<void>& mine) {
  ByteWriter w;
  w.put(static_cast<std::uint8_t>(mine ? 1 : 0));
  if (!mine) {
    w.put(static_cast<std::int32_t>(mine.error().code));
    w.putBytes(std::as_bytes(std::span<const char>(mine.error().message)));
  }
  if (comm.size() == 1) return mine;
  const auto all = comm.allGather(w.take());
  for (std::size_t r = 0; r < all.size(); ++r) {
    ByteReader in(all[r]);
    if (in.get<std::uint8_t>() == 1) continue;
    const auto code = static_cast<ErrorCode>(in.get<std::int32_t>());
    const auto text = in.take(all[r].size() - in.offset());
    std::string message(reinterpret_cast<const char*>(text.data()), text.size());
    if (r != 0) message = "rank " + std::to_string(r) + ": " + message;
    return makeError(code, message);
  }
  return {};
}

/// Everything every rank prepares identically before the distributed work.
struct Inputs {
  std::optional<Planet> planet;
  std::optional<HeightGrid> dem;  // released between resampling and the textures
  GridSource demSource;
  std::optional<GeoImage> imagery;
  std::uint32_t leafCells = 0;
  std::uint32_t depth = 0;
  std::uint32_t n = 0;
};

/// How the builder reads the DEM: a large one goes to an unnamed scratch file on the output's
/// filesystem (the nearest existing directory of --out) and is mapped, so it is not held in
/// memory (DemReader.h; the ResidentTrimmer drops its pages).
DemReadOptions demReadOptions(const BuildOptions& o) {
  DemReadOptions r;
  r.raw = o.rawLayout;
  r.mapAtBytes = o.demMapAtBytes;
  std::error_code ec;
  fs::path dir = fs::absolute(o.outDir, ec);
  if (ec) return r;
  // is_directory reports a missing path through `ec` too: that only means "go up".
  while (!fs::is_directory(dir, ec) && dir.has_relative_path()) dir = dir.parent_path();
  if (fs::is_directory(dir, ec)) r.scratchDirectory = dir;
  return r;
}

Result<Inputs> prepare(const BuildOptions& o) {
  Inputs in;
  in.leafCells = o.leafVertices - 1;
  if (o.leafVertices < 3 || !std::has_single_bit(in.leafCells) || in.leafCells > 256) {
    return invalid("--leaf-vertices " + std::to_string(o.leafVertices) +
                   ": must be 2^k + 1 between 3 and 257 (e.g. 17 or 33)");
  }
  if (o.patchVertices < 16 || o.patchVertices > kPatchMaxVertices) {
    return invalid("--patch-vertices " + std::to_string(o.patchVertices) +
                   ": must be between 16 and 65535");
  }
  if (o.textureTileTexels < 16 || o.textureTileTexels > 4096 || o.textureTileTexels % 4 != 0) {
    return invalid("--texture-tile " + std::to_string(o.textureTileTexels) +
                   ": must be a multiple of 4 between 16 and 4096");
  }
  if (o.depth && (*o.depth % 2 != 0 || *o.depth > 28)) {
    return invalid("--levels " + std::to_string(*o.depth) + ": must be an even depth up to 28");
  }
  if (!(o.heightStepMeters > 0.0) || o.threads < 0) return invalid("bad height step or threads");
  auto planet = Planet::fromSpec(o.planetSpec);
  if (!planet) return std::move(planet).error();
  in.planet = *planet;
  std::error_code ec;
  if (fs::exists(o.outDir, ec) && !fs::is_directory(o.outDir, ec)) {
    return invalid(o.outDir.string() + ": exists and is not a directory");
  }
  if (fs::exists(o.outDir / kManifestFileName, ec) && !o.force) {
    return invalid(o.outDir.string() + ": already holds a dataset (use --force to replace it)");
  }

  auto dem = readDem(o.demPath, demReadOptions(o));
  if (!dem) return std::move(dem).error();
  const std::string& body = dem->source().body;
  const std::string spec = planet->name();
  if (!body.empty() && spec.rfind(body, 0) != 0 && spec.rfind("sphere", 0) != 0 &&
      spec.rfind("ellipsoid", 0) != 0) {
    return invalid(o.demPath.string() + ": the DEM's CRS is on " + body + " but --planet is " +
                   spec);
  }
  if (!o.texturePath.empty()) {
    auto image = readImage(o.texturePath);
    if (!image) return std::move(image).error();
    in.imagery = std::move(image).value();
  }

  // Lattice size: at least the DEM's density across 90° of longitude.
  in.n = in.leafCells;
  if (o.depth) {
    in.depth = *o.depth;
    in.n = in.leafCells << (in.depth / 2);
  } else {
    const double across = 90.0 / dem->geometry().lonSpacingDegrees;
    in.n =
        std::max(in.leafCells, std::bit_ceil(static_cast<std::uint32_t>(std::ceil(across - 1e-9))));
    in.depth = 2 * static_cast<std::uint32_t>(std::countr_zero(in.n / in.leafCells));
  }
  if (in.n > 16384) {
    return invalid("the lattice would have " + std::to_string(in.n) +
                   " cells per face side; at most 16384 (choose --levels or larger leaves)");
  }
  in.dem = std::move(dem).value();
  in.demSource = in.dem->source();
  return in;
}

/// The DEM's identity in the fingerprint: the CRC-32 of its heights, in hex.
std::string demCrc32(const HeightGrid& dem) {
  // In 64 MB pieces, dropping a mapped DEM's pages after each: one pass over a 2 GB DEM would
  // otherwise bring all of it into the process's RSS.
  const auto bytes = std::as_bytes(dem.heightsMeters());
  constexpr std::size_t kPiece = std::size_t{64} << 20;
  std::uint32_t crc = 0;
  for (std::size_t at = 0; at < bytes.size(); at += kPiece) {
    crc = crc32(bytes.subspan(at, std::min(kPiece, bytes.size() - at)), crc);
    dem.releaseResident();
  }
  return hex32(crc);
}

/// The options and inputs that decide the output bytes (the checkpoint's fingerprint). Thread
/// and rank counts are not among them: they do not change the output.
std::vector<std::pair<std::string, std::string>> fingerprintOf(const BuildOptions& o,
                                                               const Inputs& in) {
  const GridGeometry& g = in.dem->geometry();
  std::vector<std::pair<std::string, std::string>> f;
  f.emplace_back("dem", o.demPath.filename().string());
  f.emplace_back("dem-grid", std::to_string(g.width) + "x" + std::to_string(g.height) + "@" +
                                 exact(g.firstLatDegrees) + "," + exact(g.firstLonDegrees) + "/" +
                                 exact(g.latSpacingDegrees) + "," + exact(g.lonSpacingDegrees) +
                                 (g.pixelIsArea ? "/area" : "/point"));
  f.emplace_back("dem-crc32", demCrc32(*in.dem));
  std::string texture = "shaded-relief";
  if (in.imagery) {
    texture = o.texturePath.filename().string() +
              "/crc32:" + hex32(crc32(std::as_bytes(std::span(in.imagery->rgba()))));
  }
  f.emplace_back("texture", texture);
  f.emplace_back("planet", in.planet->name());
  f.emplace_back("levels", std::to_string(in.depth));
  f.emplace_back("lattice", std::to_string(in.n));
  f.emplace_back("leaf-vertices", std::to_string(o.leafVertices));
  f.emplace_back("patch-vertices", std::to_string(o.patchVertices));
  f.emplace_back("texture-tile", std::to_string(o.textureTileTexels));
  f.emplace_back("texture-format", o.textureFormat == TexelFormat::Bc1 ? "bc1" : "rgba8");
  f.emplace_back("texture-quality", o.bc1Quality == Bc1Quality::High ? "high" : "fast");
  f.emplace_back("height-step", exact(o.heightStepMeters));
  return f;
}

/// What rank 0 decided about the output directory and the checkpoint, sent to every rank.
struct StartPoint {
  std::optional<int> completeLevel;      // resume after this level
  std::uint32_t completeLevelParts = 1;  // its part files (the rank count that wrote them)
  bool textureComplete = false;
};

std::string rangeText(std::uint64_t begin, std::uint64_t end) {
  char text[48];
  std::snprintf(text, sizeof text, "[%llu, %llu)", static_cast<unsigned long long>(begin),
                static_cast<unsigned long long>(end));
  return text;
}

class DistributedBuild {
 public:
  DistributedBuild(const BuildOptions& o, Communicator& comm, Inputs& in)
      : o_(o),
        comm_(comm),
        in_(in),
        lattice_(in.n),
        d_(static_cast<int>(in.depth)),
        nodesPerTree_(Lattice::nodesPerTree(d_)),
        checkpoint_(o.outDir) {}

  Result<BuildSummary> run();

 private:
  bool root() const noexcept { return comm_.rank() == 0; }
  void report(std::string_view stage, double fraction) const {
    if (root() && o_.progress) o_.progress(stage, fraction);
  }
  void log(const std::string& line) const {
    if (root() && o_.log) o_.log(line);
  }
  /// Tells the caller what every rank works on in the stage starting now.
  void announce(const std::string& stage, const std::string& unit, std::uint64_t count) const {
    if (!o_.stageStarted) return;
    std::string text = stage + " (";
    for (int r = 0; r < comm_.size(); ++r) {
      const auto [b, e] = shareOf(count, r, comm_.size());
      text +=
          (r == 0 ? "rank " : ", rank ") + std::to_string(r) + ": " + unit + " " + rangeText(b, e);
    }
    text += " of " + std::to_string(count) + "); checkpointed: ";
    if (completeLevel_) {
      text += *completeLevel_ == d_
                  ? "level " + std::to_string(d_)
                  : "levels " + std::to_string(d_) + ".." + std::to_string(*completeLevel_);
      if (textureComplete_) text += " and the textures";
    } else {
      text += "nothing yet";
    }
    o_.stageStarted(text);
  }
  /// A failure after the ranks started: one process returns it; several print it, naming
  /// this rank, its host and its work item, and stop the job.
  Error fail(const std::string& item, const Error& error) {
    if (comm_.size() == 1) return error;
    std::fprintf(stderr, "pbdam: rank %d of %d on %s failed while %s: %s\n", comm_.rank(),
                 comm_.size(), comm_.hostName().c_str(), item.c_str(), error.message.c_str());
    std::fflush(stderr);
    comm_.abortJob(1);
    return error;  // not reached: abortJob does not return
  }

  Result<StartPoint> setUpOutput();
  Result<void> resample();
  Result<void> buildLevel(int level);
  Result<void> buildTextures();
  /// Drops the pages of every mapping in use from this process (ResidentTrimmer).
  void releaseResident();
  /// Lets the DEM go (memory, or its scratch mapping), under the trimmer's lock.
  void releaseDem() {
    std::lock_guard lock(residentMutex_);
    in_.dem.reset();
  }
  /// Reads the DEM again (for the textures) and checks it is the one the build started with.
  Result<void> rereadDem();
  Result<void> assemble(BuildSummary& summary);

  NodeOut makeNode(const BinTriangle& t, const WorkPatch& patch, Error& failure,
                   std::atomic<bool>& failed);

  const BuildOptions& o_;
  Communicator& comm_;
  Inputs& in_;
  Lattice lattice_;
  int d_;
  std::uint64_t nodesPerTree_;
  Checkpoint checkpoint_;
  CheckpointState state_;
  std::optional<SampleGrid> grid_;
  std::mutex failureMutex_;

  // The carry of the level below the one being built (its diamonds' saturated errors and
  // spheres and its working patches, by node id), read from its part files.
  CarryReader below_;
  std::uint32_t belowParts_ = 0;  // part files of each level's output: the rank count
  bool verifyBelow_ = false;      // check the CRCs of a carry that a resume found
  // Mappings ResidentTrimmer releases: the grid and carry above, and while assembling these.
  std::mutex residentMutex_;
  std::vector<const MappedFile*> assembling_;

  // What the checkpoint holds (every rank keeps track, for messages).
  std::optional<int> completeLevel_;
  bool textureComplete_ = false;

  // Progress of the simplification (rank 0).
  Clock::time_point simplifyStart_;
  std::uint64_t patchesDone_ = 0;
  std::uint64_t blockPatchesDone_ = 0;  // by this run's block levels, for the ETA
  double blockSeconds_ = 0.0;
};

NodeOut DistributedBuild::makeNode(const BinTriangle& t, const WorkPatch& patch, Error& failure,
                                   std::atomic<bool>& failed) {
  NodeOut n;
  n.id = nodeId(t, d_);
  MeasuredPatch m = measurePatch(*grid_, t, patch, o_.heightStepMeters);
  optimizePatchForRendering(m.mesh);
  auto blob = encodePatch(m.mesh);
  if (!blob) {
    std::lock_guard lock(failureMutex_);
    if (!failed)
      failure = makeError(ErrorCode::Internal,
                          "patch " + std::to_string(n.id) + ": " + blob.error().message);
    failed = true;
    return n;
  }
  n.blob = std::move(blob).value();
  const NodeCorners corners = nodeCorners(*grid_, t);
  for (std::size_t c = 0; c < 3; ++c) {
    for (std::size_t a = 0; a < 3; ++a) {
      n.record.cornerPositions[c * 3 + a] = corners.positions[c][static_cast<int>(a)];
      n.record.cornerNormals[c * 3 + a] = corners.normals[c][static_cast<int>(a)];
    }
  }
  n.record.vertexCount = static_cast<std::uint32_t>(m.mesh.vertices.size());
  n.record.triangleCount = static_cast<std::uint32_t>(m.mesh.triangleCount());
  n.record.measuredErrorMeters = roundUpToFloat(m.errorMeters);
  n.record.minHeightMeters = static_cast<float>(m.minHeightMeters);
  n.record.maxHeightMeters = static_cast<float>(m.maxHeightMeters);
  n.measuredError = m.errorMeters;
  n.sphere = Sphere{m.sphereCenter, m.sphereRadiusMeters};
  return n;
}

Result<StartPoint> DistributedBuild::setUpOutput() {
  std::error_code ec;
  fs::create_directories(o_.outDir, ec);
  if (ec) return makeError(ErrorCode::IoError, o_.outDir.string() + ": " + ec.message());
  // A rebuild first makes the directory incomplete, so a crash never leaves a stale manifest
  // describing new face files.
  fs::remove(o_.outDir / kManifestFileName, ec);
  StartPoint start;
  if (o_.resume) {
    auto saved = checkpoint_.readState();
    if (!saved) return std::move(saved).error();
    if (*saved) {
      if (auto differs = fingerprintMismatch((*saved)->fingerprint, state_.fingerprint)) {
        return invalid("--resume: " + checkpoint_.directory().string() +
                       " belongs to another build: " + *differs +
                       " (rerun without --resume to start over)");
      }
      start.completeLevel = (*saved)->completeLevel;
      start.textureComplete = (*saved)->textureComplete;
      if (start.completeLevel) {
        const auto it = (*saved)->levelParts.find(*start.completeLevel);
        if (it != (*saved)->levelParts.end()) start.completeLevelParts = it->second;
      }
      // Every file the state promises must be there before any work is redone.
      std::vector<fs::path> needed;
      const CheckpointState& st = **saved;
      auto partsOf = [&](int level) {
        const auto it = st.levelParts.find(level);
        return it == st.levelParts.end() ? 1u : it->second;
      };
      if (start.completeLevel) {
        for (int level = d_; level >= *start.completeLevel; --level) {
          for (std::uint32_t part = 0; part < partsOf(level); ++part) {
            needed.push_back(checkpoint_.file(Checkpoint::Kind::Nodes, level, part));
          }
        }
        if (*start.completeLevel > 0) {
          for (std::uint32_t part = 0; part < partsOf(*start.completeLevel); ++part) {
            needed.push_back(checkpoint_.file(Checkpoint::Kind::Carry, *start.completeLevel, part));
          }
        }
      }
      if (start.textureComplete) {
        for (std::uint32_t part = 0; part < std::max(1u, st.textureParts); ++part) {
          needed.push_back(checkpoint_.file(Checkpoint::Kind::Texture, 0, part));
        }
      }
      for (const auto& path : needed) {
        if (!fs::exists(path, ec)) {
          return makeError(
              ErrorCode::CorruptData,
              "--resume: " + path.string() + " is missing (rerun without --resume to start over)");
        }
      }
      state_ = **saved;
      return start;
    }
    log("resume: no checkpoint in " + checkpoint_.directory().string() +
        ", building from the start");
  }
  if (auto r = checkpoint_.reset(true); !r) return std::move(r).error();
  if (auto r = checkpoint_.writeState(state_); !r) return std::move(r).error();
  return start;
}

void DistributedBuild::releaseResident() {
  std::lock_guard lock(residentMutex_);
  if (in_.dem) in_.dem->releaseResident();
  if (grid_) grid_->releaseResident();
  below_.releaseResident();
  for (const MappedFile* m : assembling_) (void)m->releaseResident();
}

Result<void> DistributedBuild::resample() {
  // Each rank resamples a share of the lattice rows into the one heights file and buckets a
  // share of the DEM rows into its own samples file; after a barrier every rank maps them all.
  const std::size_t n1 = std::size_t{in_.n} + 1;
  const auto [begin, end] = shareOf(6 * n1, comm_.rank(), comm_.size());
  const std::string item =
      "resampling lattice rows " + rangeText(begin, end) + " of " + std::to_string(6 * n1);
  announce("resampling", "lattice rows", 6 * n1);
  const auto t0 = Clock::now();
  const std::uint32_t bucketCells = SampleGrid::defaultBucketCells(lattice_);
  auto stats = SampleGrid::writeHeightRows(
      *in_.dem, *in_.planet, lattice_, checkpoint_.heightsFile(), static_cast<std::size_t>(begin),
      static_cast<std::size_t>(end), [&](std::size_t done, std::size_t total) {
        report("resample",
               static_cast<double>(done) / static_cast<double>(std::max<std::size_t>(total, 1)));
      });
  if (!stats) return fail(item, stats.error());
  const auto demRows = static_cast<std::uint64_t>(in_.dem->height());
  const auto [rowBegin, rowEnd] = shareOf(demRows, comm_.rank(), comm_.size());
  const auto part = static_cast<std::uint32_t>(comm_.rank());
  if (auto r = SampleGrid::writeSourceBuckets(
          *in_.dem, *in_.planet, lattice_, bucketCells, checkpoint_.samplesFile(part),
          static_cast<std::size_t>(rowBegin), static_cast<std::size_t>(rowEnd));
      !r) {
    return fail("bucketing DEM rows " + rangeText(rowBegin, rowEnd), r.error());
  }

  // Barrier: every rank's rows and samples are on disk; totals of the statistics.
  ByteWriter w;
  w.put(stats->noDataPoints);
  w.put(stats->minHeightMeters);
  w.put(stats->maxHeightMeters);
  HeightRowStats total;
  total.minHeightMeters = std::numeric_limits<float>::infinity();
  total.maxHeightMeters = -std::numeric_limits<float>::infinity();
  for (const auto& piece : comm_.allGather(w.take())) {
    ByteReader r(piece);
    total.noDataPoints += r.get<std::uint64_t>();
    total.minHeightMeters = std::min(total.minHeightMeters, r.get<float>());
    total.maxHeightMeters = std::max(total.maxHeightMeters, r.get<float>());
  }
  std::vector<fs::path> samples;
  for (std::uint32_t k = 0; k < static_cast<std::uint32_t>(comm_.size()); ++k) {
    samples.push_back(checkpoint_.samplesFile(k));
  }
  auto grid = SampleGrid::open(lattice_, *in_.planet, checkpoint_.heightsFile(), samples,
                               bucketCells, total);
  if (!grid) return fail(item, grid.error());
  {
    std::lock_guard lock(residentMutex_);
    grid_.emplace(std::move(grid).value());
  }
  const double s = std::chrono::duration<double>(Clock::now() - t0).count();
  char line[160];
  std::snprintf(line, sizeof line, "resample: %zu lattice rows over %d rank(s) in %.1f s", 6 * n1,
                comm_.size(), s);
  log(line);
  return {};
}

Result<void> DistributedBuild::buildLevel(int level) {
  const auto diamonds = diamondsOfLevel(lattice_, d_, level);
  const auto [begin, end] = shareOf(diamonds.size(), comm_.rank(), comm_.size());
  const std::string item = "building level " + std::to_string(level) + " diamonds " +
                           rangeText(begin, end) + " of " + std::to_string(diamonds.size());
  announce("level " + std::to_string(level), "diamonds", diamonds.size());
  if (o_.fault.failRank == comm_.rank() && o_.fault.failLevel == level) {
    if (o_.fault.failByKill) {
      std::fprintf(stderr, "pbdam: test: rank %d kills itself (SIGKILL) at level %d\n",
                   comm_.rank(), level);
      std::fflush(stderr);
      std::raise(SIGKILL);
    }
    return fail(item, makeError(ErrorCode::Internal, "injected failure (PBDAM_TEST_FAIL_RANK)"));
  }
  // The carry of the level below: saturated values and (above the first block level) the
  // working patches of this level's children, from the part files every rank wrote.
  if (level < d_) {
    std::lock_guard lock(residentMutex_);
    if (auto r = below_.open(checkpoint_, level + 1, belowParts_, verifyBelow_); !r) {
      return fail(item, r.error());
    }
    verifyBelow_ = false;
  }
  const auto ranks = static_cast<std::uint32_t>(comm_.size());
  const auto part = static_cast<std::uint32_t>(comm_.rank());
  auto nodesFile = checkpoint_.startFile(Checkpoint::Kind::Nodes, level, part, ranks);
  if (!nodesFile) return fail(item, nodesFile.error());
  // Level 0's carry would serve no level: it is not written.
  std::optional<Checkpoint::PartWriter> carryFile;
  if (level > 0) {
    auto c = checkpoint_.startFile(Checkpoint::Kind::Carry, level, part, ranks);
    if (!c) return fail(item, c.error());
    carryFile = std::move(c).value();
  }
  const bool keepPatches = level > 0 && level < d_;  // level − 1 is a block level over them

  // 1. Simplify, measure, saturate and serialise this rank's diamonds in batches (TBB within a
  // batch), appending each batch to the part files in diamond order: what is in memory is one
  // batch, whatever the level's size.
  const auto t0 = Clock::now();
  const std::uint64_t mine = end - begin;
  const auto threads =
      static_cast<std::uint64_t>(std::max(1, tbb::this_task_arena::max_concurrency()));
  const std::uint64_t batch = 256 * threads;
  struct DiamondBytes {
    std::vector<std::byte> nodes;
    std::vector<std::byte> carry;
    std::size_t firstCarryBytes = 0;  // the carry record of the second triangle starts here
    std::uint64_t rawBytes = 0;
  };
  std::vector<DiamondBytes> out;
  std::vector<std::pair<std::uint64_t, std::uint64_t>> carryIndex;  // node id, record offset
  carryIndex.reserve(carryFile ? 2 * mine : 0);
  std::atomic<std::uint64_t> retries{0};
  std::atomic<std::uint64_t> unsimplified{0};
  std::atomic<std::uint64_t> done{0};
  std::atomic<bool> failed{false};
  Error failure;
  auto failWith = [&](const std::string& why) {
    std::lock_guard lock(failureMutex_);
    if (!failed) failure = makeError(ErrorCode::Internal, why);
    failed = true;
  };
  std::uint64_t rawBytes = 0;
  const auto caller = std::this_thread::get_id();
  auto lastReport = Clock::now();
  const std::uint64_t total = 12 * nodesPerTree_;
  const std::uint64_t levelPatches = 2 * diamonds.size();
  for (std::uint64_t first = 0; first < mine && !failed; first += batch) {
    const std::uint64_t count = std::min(batch, mine - first);
    out.assign(count, DiamondBytes{});
    tbb::parallel_for(std::uint64_t{0}, count, [&](std::uint64_t j) {
      const Diamond& diamond = diamonds[begin + first + j];
      const std::array<BinTriangle, 2> tri = {triangleOfNode(lattice_, diamond[0], d_),
                                              triangleOfNode(lattice_, diamond[1], d_)};
      std::array<NodeOut, 2> nodes;
      std::array<WorkPatch, 2> made;
      // The four child diamonds are those whose spines are this diamond's legs: the diamonds
      // of the triangles' children (first child: leg apex–left, second: apex–right).
      std::array<Saturated, 4> childSaturated;
      if (level == d_) {
        for (std::size_t s = 0; s < 2; ++s) {
          nodes[s] = makeNode(tri[s], makeLeafPatch(tri[s]), failure, failed);
        }
      } else {
        std::array<std::array<WorkPatch, 2>, 2> children;
        std::array<std::array<const WorkPatch*, 2>, 2> childPointers{};
        for (std::size_t s = 0; s < 2; ++s) {
          const auto kids = Lattice::children(tri[s]);
          for (std::size_t c = 0; c < 2; ++c) {
            const std::uint64_t kid = nodeId(kids[c], d_);
            const bool leaf = level + 1 == d_;
            if (!below_.find(kid, childSaturated[2 * s + c], leaf ? nullptr : &children[s][c])) {
              failWith("node " + std::to_string(kid) + " is missing from the level " +
                       std::to_string(level + 1) + " carry");
              return;
            }
            if (leaf) children[s][c] = makeLeafPatch(kids[c]);
            childPointers[s][c] = &children[s][c];
          }
        }
        BlockResult block = simplifyBlock(*grid_, tri, childPointers, o_.patchVertices);
        retries += block.stats.simplifyRetries;
        unsimplified += block.stats.halvesKeptUnsimplified;
        nodes[0] = makeNode(tri[0], block.first, failure, failed);
        nodes[1] = makeNode(tri[1], block.second, failure, failed);
        made = {std::move(block.first), std::move(block.second)};
      }
      if (failed) return;

      // Saturate over the diamond DAG.
      NodeOut& a = nodes[0];
      NodeOut& b = nodes[1];
      double e = std::max(a.measuredError, b.measuredError);
      Sphere sphere = merge(a.sphere, b.sphere);
      if (level < d_) {
        for (const Saturated& child : childSaturated) {
          e = std::max(e, child.error);
          sphere = merge(sphere, child.sphere);
        }
      }
      const float storedError = roundUpToFloat(e);
      const float radius = storedRadius(sphere.radius);
      const Saturated saturated{static_cast<double>(storedError), Sphere{sphere.center, radius}};

      DiamondBytes& bytes = out[j];
      ByteWriter w;
      std::array<std::byte, kNodeRecordBytes> record{};
      for (NodeOut* node : {&a, &b}) {
        node->record.errorMeters = storedError;
        node->record.sphereRadiusMeters = radius;
        node->record.sphereCenter = {sphere.center.x, sphere.center.y, sphere.center.z};
        bytes.rawBytes += 8ULL * node->record.vertexCount + 6ULL * node->record.triangleCount;
        w.put(node->id);
        encodeNodeRecord(node->record, record);
        w.putBytes(record);
        w.put(static_cast<std::uint32_t>(node->blob.size()));
        w.putBytes(node->blob);
      }
      bytes.nodes = w.take();
      if (carryFile) {
        ByteWriter c;
        putCarry(c, saturated, keepPatches ? &made[0] : nullptr);
        bytes.firstCarryBytes = c.bytes().size();
        putCarry(c, saturated, keepPatches ? &made[1] : nullptr);
        bytes.carry = c.take();
      }
      ++done;
      if (std::this_thread::get_id() == caller && root() &&
          Clock::now() - lastReport > std::chrono::milliseconds(100)) {
        lastReport = Clock::now();
        const double share = static_cast<double>(done.load()) /
                             static_cast<double>(std::max<std::uint64_t>(mine, 1));
        report("simplify",
               (static_cast<double>(patchesDone_) + share * static_cast<double>(levelPatches)) /
                   static_cast<double>(total));
      }
    });
    if (failed) break;
    for (std::uint64_t j = 0; j < count; ++j) {
      DiamondBytes& bytes = out[j];
      rawBytes += bytes.rawBytes;
      if (auto r = nodesFile->append(bytes.nodes); !r) return fail(item, r.error());
      if (carryFile) {
        const Diamond& diamond = diamonds[begin + first + j];
        carryIndex.emplace_back(diamond[0], carryFile->size());
        carryIndex.emplace_back(diamond[1], carryFile->size() + bytes.firstCarryBytes);
        if (auto r = carryFile->append(bytes.carry); !r) return fail(item, r.error());
      }
    }
  }
  out.clear();
  if (failed) return fail(item, failure);
  const double seconds = std::chrono::duration<double>(Clock::now() - t0).count();

  // 2. Finish the part files: the nodes' footer (what the level reports), the carry's index.
  ByteWriter footer;
  footer.put(begin);
  footer.put(mine);
  footer.put(retries.load());
  footer.put(unsimplified.load());
  footer.put(rawBytes);
  footer.put(seconds);
  const std::vector<std::byte> summary = footer.bytes();
  if (auto r = nodesFile->append(summary); !r) return fail(item, r.error());
  if (auto r = nodesFile->finish(); !r) return fail(item, r.error());
  if (carryFile) {
    std::sort(carryIndex.begin(), carryIndex.end());
    ByteWriter index;
    for (const auto& [id, offset] : carryIndex) {
      index.put(id);
      index.put(offset);
    }
    index.put(static_cast<std::uint64_t>(carryIndex.size()));
    carryIndex = {};
    if (auto r = carryFile->append(index.bytes()); !r) return fail(item, r.error());
    if (auto r = carryFile->finish(); !r) return fail(item, r.error());
  }
  {
    std::lock_guard lock(residentMutex_);
    below_.close();  // the children have served
  }

  // 3. Synchronise: every rank's part files are complete; rank 0 records the level, and no
  // rank goes on before it has (otherwise a rank failing early in the next level could stop the
  // job while rank 0 writes, and a level every rank completed would be built again on resume).
  auto gathered = comm_.allGather(summary);
  patchesDone_ += levelPatches;
  const std::uint32_t previousParts = belowParts_;
  belowParts_ = ranks;
  if (root()) {
    const std::string writing = "writing the level " + std::to_string(level) + " checkpoint";
    state_.completeLevel = level;
    state_.levelParts[level] = ranks;
    if (auto w = checkpoint_.writeState(state_); !w) return fail(writing, w.error());
  }
  std::vector<std::byte> recorded(1);
  comm_.broadcast(recorded);
  completeLevel_ = level;
  if (!root()) return {};
  if (level < d_) checkpoint_.removeFile(Checkpoint::Kind::Carry, level + 1, previousParts);

  // 4. Report: per-rank throughput and the ETA of the simplification.
  std::string line = "level " + std::to_string(level) + ": " + std::to_string(diamonds.size()) +
                     (level == d_ ? " leaf diamonds" : " blocks");
  char buf[200];
  for (std::size_t r = 0; r < gathered.size(); ++r) {
    ByteReader in(gathered[r]);
    (void)in.get<std::uint64_t>();
    const auto count = in.get<std::uint64_t>();
    (void)in.get<std::uint64_t>();
    (void)in.get<std::uint64_t>();
    (void)in.get<std::uint64_t>();
    const auto s = in.get<double>();
    std::snprintf(buf, sizeof buf, "%s rank %zu %llu in %.1f s (%.0f/s)", r == 0 ? ";" : ",", r,
                  static_cast<unsigned long long>(count), s,
                  s > 0.0 ? static_cast<double>(count) / s : 0.0);
    line += buf;
  }
  const double elapsed = std::chrono::duration<double>(Clock::now() - simplifyStart_).count();
  const double fraction = static_cast<double>(patchesDone_) / static_cast<double>(total);
  std::snprintf(buf, sizeof buf, "; %.0f%% of patches, %.1f s", 100.0 * fraction, elapsed);
  line += buf;
  // Blocks cost ~10x what leaves do: the ETA extrapolates the block levels' rate only.
  if (level < d_) {
    blockSeconds_ += std::chrono::duration<double>(Clock::now() - t0).count();
    blockPatchesDone_ += levelPatches;
    std::snprintf(buf, sizeof buf, ", ETA %.0f s",
                  blockSeconds_ / static_cast<double>(blockPatchesDone_) *
                      static_cast<double>(total - patchesDone_));
    line += buf;
  }
  log(line);
  report("simplify", fraction);
  return {};
}

Result<void> DistributedBuild::rereadDem() {
  const auto t0 = Clock::now();
  auto dem = readDem(o_.demPath, demReadOptions(o_));
  if (!dem) return std::move(dem).error();
  const std::string crc = demCrc32(*dem);
  for (const auto& [key, value] : state_.fingerprint) {
    if (key == "dem-crc32" && value != crc) {
      return makeError(ErrorCode::InvalidArgument,
                       o_.demPath.string() + ": changed during the build (CRC-32 " + crc +
                           ", was " + value + " when the build started)");
    }
  }
  {
    std::lock_guard lock(residentMutex_);  // the trimmer releases the DEM's pages too
    in_.dem = std::move(dem).value();
  }
  char line[120];
  std::snprintf(line, sizeof line, "texture: DEM read again in %.1f s",
                std::chrono::duration<double>(Clock::now() - t0).count());
  log(line);
  return {};
}

Result<void> DistributedBuild::buildTextures() {
  const std::uint32_t border = 2;
  const std::uint32_t inner = o_.textureTileTexels - 2 * border;
  const double ratio = static_cast<double>(in_.n) / static_cast<double>(inner);
  const auto textureLevels =
      static_cast<std::uint32_t>(std::max(0.0, std::round(std::log2(std::max(ratio, 1.0))))) + 1;
  const std::uint64_t tilesPerFace = ((std::uint64_t{1} << (2 * textureLevels)) - 1) / 3;
  const std::uint64_t tiles = 6 * tilesPerFace;
  const auto [begin, end] = shareOf(tiles, comm_.rank(), comm_.size());
  const std::string item =
      "building texture tiles " + rangeText(begin, end) + " of " + std::to_string(tiles);
  announce("texture", "tiles", tiles);
  if (!in_.dem) {
    if (auto r = rereadDem(); !r) return fail(item, r.error());
  }
  const SampleGrid& grid = *grid_;
  TextureSource source;
  source.planet = *in_.planet;
  source.heightMeters = heightFunctionFromGrid(*in_.dem, true);
  source.ramp.hasOcean = grid.minHeightMeters() < 0.0f && in_.demSource.body == "earth";
  if (!source.ramp.hasOcean && in_.planet->name() == "earth") source.ramp.hasOcean = true;
  source.ramp.minMeters = static_cast<double>(grid.minHeightMeters());
  source.ramp.maxMeters =
      std::max(static_cast<double>(grid.maxHeightMeters()), source.ramp.minMeters + 1.0);
  if (in_.imagery) {
    source.imagery = &*in_.imagery;
    source.imageryShadingStrength = 0.35;
  }
  const auto t0 = Clock::now();
  const std::uint64_t mine = end - begin;
  const auto ranks = static_cast<std::uint32_t>(comm_.size());
  auto file = checkpoint_.startFile(Checkpoint::Kind::Texture, 0,
                                    static_cast<std::uint32_t>(comm_.rank()), ranks);
  if (!file) return fail(item, file.error());
  const auto threads =
      static_cast<std::uint64_t>(std::max(1, tbb::this_task_arena::max_concurrency()));
  const std::uint64_t batch = 16 * threads;  // tiles in memory at once
  std::vector<std::vector<std::byte>> blobs;
  std::vector<float> errors;
  std::atomic<std::uint64_t> done{0};
  std::atomic<std::int64_t> failedTile{-1};
  const auto caller = std::this_thread::get_id();
  auto lastReport = Clock::now();
  for (std::uint64_t first = 0; first < mine && failedTile < 0; first += batch) {
    const std::uint64_t count = std::min(batch, mine - first);
    blobs.assign(count, {});
    errors.assign(count, 0.0f);
    tbb::parallel_for(std::uint64_t{0}, count, [&](std::uint64_t j) {
      const std::uint64_t k = begin + first + j;
      const auto face = static_cast<int>(k / tilesPerFace);
      const std::uint64_t heap = k % tilesPerFace;
      std::uint32_t level = 0;
      while (((std::uint64_t{1} << (2 * (level + 1))) - 1) / 3 <= heap) ++level;
      const std::uint64_t within = heap - ((std::uint64_t{1} << (2 * level)) - 1) / 3;
      TextureTileRequest request;
      request.face = face;
      request.level = static_cast<int>(level);
      request.qi = static_cast<std::uint32_t>(within & ((std::uint64_t{1} << level) - 1));
      request.qj = static_cast<std::uint32_t>(within >> level);
      request.sizeTexels = o_.textureTileTexels;
      request.borderTexels = border;
      auto tile = buildTextureTile(source, request);
      if (!tile) {
        failedTile = static_cast<std::int64_t>(k);
        return;
      }
      TextureTileImage image = std::move(tile->image);
      if (o_.textureFormat == TexelFormat::Bc1) {
        auto bc1 = compressBc1(image, o_.bc1Quality);
        if (!bc1) {
          failedTile = static_cast<std::int64_t>(k);
          return;
        }
        image = std::move(bc1).value();
      }
      auto blob = encodeTextureTile(image);
      if (!blob) {
        failedTile = static_cast<std::int64_t>(k);
        return;
      }
      blobs[j] = std::move(blob).value();
      errors[j] = roundUpToFloat(tile->textureErrorMeters);
      ++done;
      if (std::this_thread::get_id() == caller && root() &&
          Clock::now() - lastReport > std::chrono::milliseconds(100)) {
        lastReport = Clock::now();
        report("texture", static_cast<double>(done.load()) /
                              static_cast<double>(std::max<std::uint64_t>(mine, 1)));
      }
    });
    if (failedTile >= 0) break;
    ByteWriter w;
    for (std::uint64_t j = 0; j < count; ++j) {
      w.put(errors[j]);
      w.put(static_cast<std::uint32_t>(blobs[j].size()));
      w.putBytes(blobs[j]);
    }
    if (auto r = file->append(w.bytes()); !r) return fail(item, r.error());
  }
  blobs.clear();
  if (failedTile >= 0) {
    return fail(item,
                makeError(ErrorCode::Internal, "texture tile " + std::to_string(failedTile.load()) +
                                                   " could not be built"));
  }
  const double seconds = std::chrono::duration<double>(Clock::now() - t0).count();
  ByteWriter footer;
  footer.put(begin);
  footer.put(mine);
  footer.put(seconds);
  const std::vector<std::byte> summary = footer.bytes();
  if (auto r = file->append(summary); !r) return fail(item, r.error());
  if (auto r = file->finish(); !r) return fail(item, r.error());
  auto gathered = comm_.allGather(summary);
  if (!root()) {
    textureComplete_ = true;
    return {};
  }
  report("texture", 1.0);
  const std::string writing = "writing the texture checkpoint";
  state_.textureComplete = true;
  state_.textureParts = ranks;
  if (auto w = checkpoint_.writeState(state_); !w) return fail(writing, w.error());
  textureComplete_ = true;
  std::string line = "texture: " + std::to_string(tiles) + " tiles";
  char buf[120];
  for (std::size_t r = 0; r < gathered.size(); ++r) {
    ByteReader in(gathered[r]);
    (void)in.get<std::uint64_t>();
    const auto count = in.get<std::uint64_t>();
    const auto s = in.get<double>();
    std::snprintf(buf, sizeof buf, "%s rank %zu %llu in %.1f s (%.1f/s)", r == 0 ? ";" : ",", r,
                  static_cast<unsigned long long>(count), s,
                  s > 0.0 ? static_cast<double>(count) / s : 0.0);
    line += buf;
  }
  log(line);
  return {};
}

/// Rank 0: the face files and the manifest from the checkpointed levels and tiles, read
/// through mappings (the blobs are never all in memory at once).
Result<void> DistributedBuild::assemble(BuildSummary& summary) {
  struct Located {
    const std::byte* record = nullptr;
    std::span<const std::byte> blob;
  };
  const std::uint64_t nodeCount = 12 * nodesPerTree_;
  std::vector<Located> located(nodeCount);
  // Mappings of every part file; ResidentTrimmer drops their pages as the faces are written.
  std::vector<std::unique_ptr<MappedFile>> mappings;
  auto keep = [&](MappedFile mapped) {
    mappings.push_back(std::make_unique<MappedFile>(std::move(mapped)));
    std::lock_guard lock(residentMutex_);
    assembling_.push_back(mappings.back().get());
  };
  struct Unregister {  // before `mappings` go, on every return
    DistributedBuild& build;
    ~Unregister() {
      std::lock_guard lock(build.residentMutex_);
      build.assembling_.clear();
    }
  } unregister{*this};
  auto partsOf = [&](int level) {
    const auto it = state_.levelParts.find(level);
    return it == state_.levelParts.end() ? 1u : it->second;
  };
  constexpr std::size_t kNodesFooterBytes = 6 * 8;
  constexpr std::size_t kReleaseEvery = std::size_t{64} << 20;
  for (int level = 0; level <= d_; ++level) {
    for (std::uint32_t part = 0; part < partsOf(level); ++part) {
      const std::string path = checkpoint_.file(Checkpoint::Kind::Nodes, level, part).string();
      std::span<const std::byte> payload;
      auto mapped = checkpoint_.openFile(Checkpoint::Kind::Nodes, level, part, payload);
      if (!mapped) return std::move(mapped).error();
      // RSS bound: the walk below reads a record header on nearly every page (blobs average a
      // few KB), so the mapping is handed to the trimmer first and released every 64 MB —
      // registered only afterwards, a paper-scale leaf level's 11 GB file became resident whole.
      keep(std::move(mapped).value());
      const MappedFile& nodesFile = *mappings.back();
      std::size_t releasedUpTo = 0;
      if (payload.size() < kNodesFooterBytes) {
        return makeError(ErrorCode::CorruptData, path + ": truncated");
      }
      ByteReader f(payload.last(kNodesFooterBytes));
      (void)f.get<std::uint64_t>();
      const auto count = f.get<std::uint64_t>();
      summary.simplifyRetries += f.get<std::uint64_t>();
      summary.halvesKeptUnsimplified += f.get<std::uint64_t>();
      summary.patchBytesRaw += f.get<std::uint64_t>();
      ByteReader r(payload.first(payload.size() - kNodesFooterBytes));
      for (std::uint64_t k = 0; k < 2 * count && !r.failed(); ++k) {
        const auto id = r.get<std::uint64_t>();
        const auto record = r.take(kNodeRecordBytes);
        const auto bytes = r.get<std::uint32_t>();
        const auto blob = r.take(bytes);
        if (r.failed() || id >= nodeCount) break;
        if (r.offset() - releasedUpTo >= kReleaseEvery) {
          (void)nodesFile.releaseResident();
          releasedUpTo = r.offset();
        }
        located[id] = Located{record.data(), blob};
        const NodeRecord rec = decodeNodeRecord(
            std::span<const std::byte, kNodeRecordBytes>(record.data(), kNodeRecordBytes));
        if (level == d_) {
          summary.leafMaxErrorMeters =
              std::max(summary.leafMaxErrorMeters, static_cast<double>(rec.errorMeters));
        }
        if (level == 0) {
          summary.rootErrorMeters =
              std::max(summary.rootErrorMeters, static_cast<double>(rec.errorMeters));
        }
      }
      if (r.failed() || !r.atEnd()) return makeError(ErrorCode::CorruptData, path + ": truncated");
      (void)nodesFile.releaseResident();
    }
  }
  for (std::uint64_t id = 0; id < nodeCount; ++id) {
    if (located[id].record == nullptr) {
      return makeError(ErrorCode::CorruptData, checkpoint_.directory().string() + ": node " +
                                                   std::to_string(id) + " is missing");
    }
  }

  const std::uint32_t border = 2;
  const std::uint32_t inner = o_.textureTileTexels - 2 * border;
  const double ratio = static_cast<double>(in_.n) / static_cast<double>(inner);
  const auto textureLevels =
      static_cast<std::uint32_t>(std::max(0.0, std::round(std::log2(std::max(ratio, 1.0))))) + 1;
  summary.textureLevels = textureLevels;
  const std::uint64_t tilesPerFace = ((std::uint64_t{1} << (2 * textureLevels)) - 1) / 3;
  std::vector<std::span<const std::byte>> tileBlobs(6 * tilesPerFace);
  std::vector<float> tileErrors(6 * tilesPerFace);
  {
    constexpr std::size_t kTilesFooterBytes = 3 * 8;
    std::uint64_t seen = 0;
    for (std::uint32_t part = 0; part < std::max(1u, state_.textureParts); ++part) {
      const std::string path = checkpoint_.file(Checkpoint::Kind::Texture, 0, part).string();
      std::span<const std::byte> payload;
      auto mapped = checkpoint_.openFile(Checkpoint::Kind::Texture, 0, part, payload);
      if (!mapped) return std::move(mapped).error();
      if (payload.size() < kTilesFooterBytes) {
        return makeError(ErrorCode::CorruptData, path + ": incomplete");
      }
      ByteReader f(payload.last(kTilesFooterBytes));
      const auto first = f.get<std::uint64_t>();
      const auto count = f.get<std::uint64_t>();
      ByteReader r(payload.first(payload.size() - kTilesFooterBytes));
      for (std::uint64_t k = first; k < first + count && !r.failed(); ++k) {
        const auto e = r.get<float>();
        const auto bytes = r.get<std::uint32_t>();
        const auto blob = r.take(bytes);
        if (r.failed() || k >= tileBlobs.size()) break;
        tileErrors[k] = e;
        tileBlobs[k] = blob;
        ++seen;
      }
      if (r.failed() || !r.atEnd()) return makeError(ErrorCode::CorruptData, path + ": incomplete");
      keep(std::move(mapped).value());
    }
    if (seen != tileBlobs.size()) {
      return makeError(ErrorCode::CorruptData,
                       checkpoint_.file(Checkpoint::Kind::Texture, 0).string() + ": incomplete");
    }
  }
  summary.textureTiles = 6 * tilesPerFace;

  const SampleGrid& grid = *grid_;
  Manifest manifest;
  manifest.version = kDatasetFormatVersion;
  manifest.planetSpec = in_.planet->name();
  manifest.equatorialRadiusMeters = in_.planet->equatorialRadiusMeters();
  manifest.flattening = in_.planet->flattening();
  manifest.latticeCells = in_.n;
  manifest.leafCells = in_.leafCells;
  manifest.depth = in_.depth;
  manifest.patchVertices = o_.patchVertices;
  manifest.heightStepMeters = o_.heightStepMeters;
  manifest.textureLevels = textureLevels;
  manifest.textureTileTexels = o_.textureTileTexels;
  manifest.textureBorderTexels = border;
  manifest.textureFormat = o_.textureFormat == TexelFormat::Bc1 ? "bc1" : "rgba8";
  manifest.textureSource = "shaded-relief";
  if (in_.imagery) {
    manifest.textureSource = "image:";
    manifest.textureSource += o_.texturePath.filename().string();
  }
  manifest.sourceDem = o_.demPath.filename().string();
  manifest.sourceFormat = in_.demSource.format;
  manifest.sourceSamples = summary.sourceSamples;
  manifest.minHeightMeters = static_cast<double>(grid.minHeightMeters());
  manifest.maxHeightMeters = static_cast<double>(grid.maxHeightMeters());

  for (int face = 0; face < 6; ++face) {
    FaceHeader h;
    h.face = static_cast<std::uint32_t>(face);
    h.latticeCells = in_.n;
    h.leafCells = in_.leafCells;
    h.depth = in_.depth;
    h.textureLevels = textureLevels;
    h.textureTileTexels = o_.textureTileTexels;
    h.textureBorderTexels = border;
    h.nodeCount = 2 * nodesPerTree_;
    h.nodeTableOffset = kFaceHeaderBytes;
    h.textureNodeCount = tilesPerFace;
    h.textureTableOffset = h.nodeTableOffset + h.nodeCount * kNodeRecordBytes;
    const std::uint64_t tablesEnd = h.textureTableOffset + tilesPerFace * kTextureRecordBytes;
    h.blobsOffset = (tablesEnd + 4095) / 4096 * 4096;  // page-aligned blob area
    std::uint64_t at = h.blobsOffset;
    std::vector<std::byte> nodeTable(h.nodeCount * kNodeRecordBytes);
    std::vector<std::span<const std::byte>> blobs;
    const std::uint64_t firstNode = static_cast<std::uint64_t>(face) * 2 * nodesPerTree_;
    for (std::uint64_t k = 0; k < h.nodeCount; ++k) {
      const Located& node = located[firstNode + k];
      NodeRecord record = decodeNodeRecord(
          std::span<const std::byte, kNodeRecordBytes>(node.record, kNodeRecordBytes));
      record.blobOffset = at;
      record.blobBytes = static_cast<std::uint32_t>(node.blob.size());
      at += node.blob.size();
      blobs.emplace_back(node.blob);
      encodeNodeRecord(record, std::span<std::byte, kNodeRecordBytes>(
                                   nodeTable.data() + k * kNodeRecordBytes, kNodeRecordBytes));
      summary.patchBytesCompressed += node.blob.size();
      summary.totalTriangles += record.triangleCount;
      if (k % nodesPerTree_ >= Lattice::firstIndexOfLevel(d_)) {
        summary.leafTriangles += record.triangleCount;
      }
    }
    std::vector<std::byte> textureTable(tilesPerFace * kTextureRecordBytes);
    for (std::uint64_t k = 0; k < tilesPerFace; ++k) {
      const auto& blob = tileBlobs[static_cast<std::size_t>(face) * tilesPerFace + k];
      TextureRecord t{at, static_cast<std::uint32_t>(blob.size()),
                      tileErrors[static_cast<std::size_t>(face) * tilesPerFace + k]};
      at += blob.size();
      blobs.emplace_back(blob);
      encodeTextureRecord(t,
                          std::span<std::byte, kTextureRecordBytes>(
                              textureTable.data() + k * kTextureRecordBytes, kTextureRecordBytes));
    }
    h.fileBytes = at;
    h.nodeTableCrc = crc32(nodeTable);
    h.textureTableCrc = crc32(textureTable);
    std::array<std::byte, kFaceHeaderBytes> header{};
    encodeFaceHeader(h, header);
    std::vector<std::byte> padding(h.blobsOffset - tablesEnd);
    const std::string name = "face" + std::to_string(face) + ".pbdam";
    auto file = AtomicFileWriter::create(o_.outDir / name);
    if (!file) return std::move(file).error();
    for (std::span<const std::byte> chunk : std::initializer_list<std::span<const std::byte>>{
             header, nodeTable, textureTable, padding}) {
      if (auto w = file->append(chunk); !w) return w;
    }
    for (const auto& blob : blobs) {
      if (auto w = file->append(blob); !w) return w;
    }
    const std::uint32_t crc = file->crc();
    if (auto w = file->finish(); !w) return w;
    manifest.faces[static_cast<std::size_t>(face)] = ManifestFace{name, h.fileBytes, crc};
    summary.datasetBytes += h.fileBytes;
    report("write", static_cast<double>(face + 1) / 6.0);
  }
  syncDirectory(o_.outDir);
  const std::string json = manifestToJson(manifest);
  std::uint32_t crc = 0;
  if (auto w = writeFileAtomically(o_.outDir / kManifestFileName,
                                   {std::as_bytes(std::span<const char>(json.data(), json.size()))},
                                   crc);
      !w) {
    return w;
  }
  syncDirectory(o_.outDir);
  summary.datasetBytes += json.size();
  summary.patches = nodeCount;
  // The dataset is complete: its checkpoint has served.
  if (auto r = checkpoint_.reset(false); !r) return r;
  return {};
}

Result<BuildSummary> DistributedBuild::run() {
  BuildSummary summary;
  summary.latticeCells = in_.n;
  summary.depth = in_.depth;
  summary.ranks = comm_.size();
  state_.fingerprint = fingerprintOf(o_, in_);

  // Rank 0 prepares the output directory and the checkpoint and tells everyone where to start.
  std::vector<std::byte> decision;
  if (root()) {
    auto start = setUpOutput();
    ByteWriter w;
    w.put(static_cast<std::uint8_t>(start ? 1 : 0));
    if (start) {
      w.put(static_cast<std::int32_t>(start->completeLevel.value_or(-1)));
      w.put(start->completeLevelParts);
      w.put(static_cast<std::uint8_t>(start->textureComplete ? 1 : 0));
    } else {
      w.put(static_cast<std::int32_t>(start.error().code));
      w.putBytes(std::as_bytes(std::span<const char>(start.error().message)));
    }
    decision = w.take();
  }
  comm_.broadcast(decision);
  StartPoint start;
  {
    ByteReader r(decision);
    if (r.get<std::uint8_t>() != 1) {
      const auto code = static_cast<ErrorCode>(r.get<std::int32_t>());
      const auto text = r.take(decision.size() - r.offset());
      return makeError(code, std::string(reinterpret_cast<const char*>(text.data()), text.size()));
    }
    const auto level = r.get<std::int32_t>();
    if (level >= 0) start.completeLevel = level;
    start.completeLevelParts = r.get<std::uint32_t>();
    start.textureComplete = r.get<std::uint8_t>() == 1;
  }
  completeLevel_ = start.completeLevel;
  textureComplete_ = start.textureComplete;
  if (start.completeLevel) {
    summary.resumedAfterLevel = start.completeLevel;
    summary.resumedAfterTexture = start.textureComplete;
    log("resume: the checkpoint has levels " + std::to_string(d_) + ".." +
        std::to_string(*start.completeLevel) + (start.textureComplete ? " and the textures" : "") +
        "; continuing" +
        (*start.completeLevel > 0 ? " at level " + std::to_string(*start.completeLevel - 1) : ""));
  }

  // RSS bound: mapped data (heights, samples, carry, checkpoint files) stays in the page cache,
  // not in this process, beyond what its threads touched in the last quarter second.
  ResidentTrimmer trimmer(std::chrono::milliseconds(250), [this] { releaseResident(); });

  // ---- Resample (each rank a share of the lattice rows and of the DEM rows, into files that
  // every rank then maps).
  if (auto r = resample(); !r) return std::move(r).error();
  summary.sourceSamples = grid_->sourceSampleCount();
  summary.latticeSamples = 6ULL * (in_.n + 1ULL) * (in_.n + 1ULL);
  summary.noDataPoints = grid_->noDataPoints();

  // RSS bound: the levels read the lattice and the bucketed samples only, so the DEM (the
  // largest thing in memory: 2.1 GB of floats for the paper-scale 32768×16384 input) is released
  // until the textures read it again.
  releaseDem();

  // ---- Levels D .. 0: leaves, then one block per diamond; saturation with each level.
  simplifyStart_ = Clock::now();
  int next = d_;
  if (start.completeLevel) {
    for (int level = d_; level >= *start.completeLevel; --level) {
      patchesDone_ += 2 * diamondsOfLevel(lattice_, d_, level).size();
    }
    next = *start.completeLevel - 1;
    belowParts_ = start.completeLevelParts;
    verifyBelow_ = true;
  }
  for (int level = next; level >= 0; --level) {
    if (auto r = buildLevel(level); !r) return std::move(r).error();
  }

  // ---- Texture quadtree.
  if (!start.textureComplete) {
    if (auto r = buildTextures(); !r) return std::move(r).error();
  }

  // RSS bound: the assembly reads checkpoint files only, so the DEM the textures read again
  // (2.17 GB at the paper scale) goes before it. The paper-scale 2 × 1 run without this peaked
  // at 5,115 MB on rank 0 (which assembles) against 3,465 MB on rank 1.
  releaseDem();

  // ---- Face files, then the manifest (rank 0).
  if (root()) {
    if (auto r = assemble(summary); !r) return fail("writing the dataset", r.error());
  }
  return summary;
}

}  // namespace

Result<BuildSummary> buildDataset(const BuildOptions& o) {
  const auto start = Clock::now();
  LocalCommunicator local;
  Communicator& comm = o.communicator ? *o.communicator : local;
  auto inputs = prepare(o);
  if (auto agreed = agree(comm, inputs ? Result<void>{} : Result<void>{inputs.error()}); !agreed) {
    return std::move(agreed).error();
  }

  tbb::task_arena arena(o.threads > 0 ? o.threads : tbb::task_arena::automatic);
  Result<BuildSummary> result = Error{};
  arena.execute([&] {
    DistributedBuild build(o, comm, *inputs);
    result = build.run();
  });
  if (result) {
    result->seconds = std::chrono::duration<double>(Clock::now() - start).count();
  }
  return result;
}

}  // namespace pbdam::builder
