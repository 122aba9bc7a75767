// `pbdam build` on a disk that fills up, simulated without privileges: a file-size limit
// (RLIMIT_FSIZE set in the child before exec, as `ulimit -f` does) smaller than one face file,
// and an injected ENOSPC (PBDAM_TEST_FAIL_WRITE) on each kind of file the builder writes. Every
// time the build exits with code 2 and one message naming the file and the bytes it needed,
// leaves no manifest.json, and `--resume` without the fault finishes to the bytes of an
// uninterrupted build.
#include <fcntl.h>
#include <gtest/gtest.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <iterator>
#include <limits>
#include <string>
#include <vector>

#include "TestData.h"

namespace pbdam::tools {
namespace {

namespace fs = std::filesystem;

struct BuildRun {
  int exitCode = -1;
  std::string err;
};

/// The small MOLA build of the distributed-build tests (about 2 s).
std::vector<std::string> buildArgs(const fs::path& dem, const fs::path& out) {
  return {PBDAM_EXE,
          "build",
          "--dem",
          dem.string(),
          "--planet",
          "mars",
          "--levels",
          "6",
          "--leaf-vertices",
          "17",
          "--min-patch-triangles",
          "128",
          "--texture-tile",
          "64",
          "--texture-format",
          "rgba8",
          "--threads",
          "1",
          "--quiet",
          "--out",
          out.string()};
}

/// Runs `args` with stderr to a file, under a file-size limit of `fileLimitBytes` (none when
/// max) and with PBDAM_TEST_FAIL_WRITE=`failWrite` when not empty.
BuildRun run(const std::vector<std::string>& args, const fs::path& errFile,
             rlim_t fileLimitBytes = RLIM_INFINITY, const std::string& failWrite = {}) {
  const pid_t pid = ::fork();
  if (pid == 0) {
    const int fd = ::open(errFile.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    const int null = ::open("/dev/null", O_WRONLY);
    if (fd < 0 || null < 0 || ::dup2(fd, STDERR_FILENO) < 0 || ::dup2(null, STDOUT_FILENO) < 0) {
      ::_exit(120);
    }
    if (fileLimitBytes != RLIM_INFINITY) {
      // The limit applies to the stderr file too: it is far below it.
      const rlimit limit{fileLimitBytes, fileLimitBytes};
      if (::setrlimit(RLIMIT_FSIZE, &limit) != 0) ::_exit(121);
    }
    if (failWrite.empty()) {
      ::unsetenv("PBDAM_TEST_FAIL_WRITE");
    } else {
      ::setenv("PBDAM_TEST_FAIL_WRITE", failWrite.c_str(), 1);
    }
    std::vector<char*> argv;
    argv.reserve(args.size() + 1);
    for (const std::string& a : args) argv.push_back(const_cast<char*>(a.c_str()));
    argv.push_back(nullptr);
    ::execv(argv[0], argv.data());
    ::_exit(122);
  }
  int status = 0;
  ::waitpid(pid, &status, 0);
  BuildRun r;
  r.exitCode = WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
  r.err = test::readFile(errFile);
  return r;
}

void expectSameDataset(const fs::path& a, const fs::path& b) {
  int files = 0;
  for (const auto& entry : fs::directory_iterator(a)) {
    const auto name = entry.path().filename();
    ASSERT_TRUE(fs::exists(b / name)) << b / name;
    EXPECT_TRUE(test::readFile(a / name) == test::readFile(b / name)) << name << " differs";
    ++files;
  }
  EXPECT_EQ(files, 7);  // six faces and the manifest: no checkpoint left behind
  EXPECT_FALSE(fs::exists(b / ".build-checkpoint"));
}

class BuildFaults : public ::testing::Test {
 protected:
  void SetUp() override {
    dem_ = test::dataDir() / "mars/megt90n000cb.lbl";
    if (const std::string missing = test::missingFileMessage(dem_); !missing.empty()) {
      if (test::runningInCi()) FAIL() << missing;
      GTEST_SKIP() << missing;
    }
    const BuildRun plain = run(buildArgs(dem_, dir_ / "plain"), dir_ / "plain.err");
    ASSERT_EQ(plain.exitCode, 0) << plain.err;
  }
  fs::path dem_;
  test::TempDir dir_;
};

TEST_F(BuildFaults, AFileSizeLimitBelowAFaceFileStopsWithCode2AndResumeFinishes) {
  std::uintmax_t smallestFace = std::numeric_limits<std::uintmax_t>::max();
  for (int face = 0; face < 6; ++face) {
    smallestFace = std::min(
        smallestFace, fs::file_size(dir_ / "plain" / ("face" + std::to_string(face) + ".pbdam")));
  }
  const fs::path out = dir_ / "limited";
  const BuildRun limited = run(buildArgs(dem_, out), dir_ / "limited.err", smallestFace - 1);
  EXPECT_EQ(limited.exitCode, 2) << limited.err;
  EXPECT_NE(limited.err.find("pbdam: " + out.string()), std::string::npos) << limited.err;
  EXPECT_NE(limited.err.find(": no space to "), std::string::npos) << limited.err;
  EXPECT_NE(limited.err.find(" bytes (File too large)"), std::string::npos) << limited.err;
  EXPECT_NE(limited.err.find("rerun with --resume"), std::string::npos) << limited.err;
  EXPECT_FALSE(fs::exists(out / "manifest.json"));

  std::vector<std::string> resume = buildArgs(dem_, out);
  resume.emplace_back("--resume");
  const BuildRun resumed = run(resume, dir_ / "resumed.err");
  ASSERT_EQ(resumed.exitCode, 0) << resumed.err;
  expectSameDataset(dir_ / "plain", out);
}

TEST_F(BuildFaults, EveryWriterReportsAFullDiskAndResumeFinishes) {
  // One injected ENOSPC per kind of file: the lattice heights (pwrite), the bucketed samples
  // (a mapping), the checkpoint state, level part files (nodes, carry), the texture part, a
  // face file and the manifest.
  int builds = 0;  // output directories are numbered: their names must not match `file`
  for (const std::string file :
       {"heights.f32", "samples.part-0.bin", "state", "level-06.part-0.nodes",
        "level-03.part-0.carry", "texture.part-0.tiles", "face4.pbdam", "manifest.json"}) {
    SCOPED_TRACE(file);
    const fs::path out = dir_ / ("full" + std::to_string(++builds));
    const BuildRun full = run(buildArgs(dem_, out), dir_ / "full.err", RLIM_INFINITY, file);
    EXPECT_EQ(full.exitCode, 2) << full.err;
    // Named as written: the samples file through its temporary name, the others as they are.
    EXPECT_NE(full.err.find(file), std::string::npos) << full.err;
    EXPECT_NE(full.err.find(": no space to "), std::string::npos) << full.err;
    EXPECT_NE(full.err.find(" bytes (No space left on device); free space"), std::string::npos)
        << full.err;
    EXPECT_FALSE(fs::exists(out / "manifest.json"));
    std::vector<std::string> resume = buildArgs(dem_, out);
    resume.emplace_back("--resume");
    const BuildRun resumed = run(resume, dir_ / "resumed.err");
    ASSERT_EQ(resumed.exitCode, 0) << resumed.err;
    expectSameDataset(dir_ / "plain", out);
  }
}

}  // namespace
}  // namespace pbdam::tools
