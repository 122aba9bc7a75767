// The distributed build as a user runs it (docs/builder.md "Distributed build"):
// `mpirun -np N pbdam build` on MOLA gives the plain build's bytes for N = 1, 2, 3 (and a hybrid
// ETOPO20 + Luxembourg build on 2 ranks); a rank that
// dies (SIGKILL, by the fault-injection hook or by a real `kill -9` from outside) or reports an
// error stops the job promptly with a message naming the rank and its work item; `--resume`
// then completes the dataset to the same bytes, also with another rank count; a checkpoint of
// other options is refused. OpenMPI as root needs --allow-run-as-root; --oversubscribe lets 3
// ranks share 2 cores.
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <array>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>
#include <thread>

#include "TestData.h"

namespace pbdam::tools {
namespace {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

struct ShellRun {
  int exitCode = -1;
  std::string out;
  std::string err;
  double seconds = 0.0;
};

/// Runs a shell command line, capturing stdout and stderr.
ShellRun runShell(const std::string& command) {
  test::TempDir dir;
  const std::string errFile = (dir / "stderr.txt").string();
  const std::string full = command + " 2>'" + errFile + "'";
  ShellRun run;
  const auto start = Clock::now();
  FILE* pipe = ::popen(full.c_str(), "r");
  if (pipe == nullptr) return run;
  std::array<char, 4096> buf{};
  std::size_t n = 0;
  while ((n = std::fread(buf.data(), 1, buf.size(), pipe)) > 0) run.out.append(buf.data(), n);
  const int status = ::pclose(pipe);
  run.seconds = std::chrono::duration<double>(Clock::now() - start).count();
  run.exitCode = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  run.err = test::readFile(errFile);
  return run;
}

std::string mpirun(int ranks) {
  return std::string("'") + PBDAM_MPIRUN +
         "' --allow-run-as-root --oversubscribe --bind-to none -np " + std::to_string(ranks) + " ";
}

/// The small MOLA build of these tests: lattice 128, depth 6, 17-vertex leaves, RGBA8 tiles
/// (about 2 s per build here).
std::string buildArgs(const fs::path& dem, const fs::path& out, int minPatchTriangles = 128) {
  return std::string("'") + PBDAM_EXE + "' build --dem '" + dem.string() +
         "' --planet mars --levels 6 --leaf-vertices 17 --min-patch-triangles " +
         std::to_string(minPatchTriangles) +
         " --texture-tile 64 --texture-format rgba8 --threads 1 --out '" + out.string() + "'";
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
}

/// The `complete-level N` of a checkpoint state file, or -1.
int completeLevel(const fs::path& out) {
  std::ifstream in(out / ".build-checkpoint" / "state");
  std::string line;
  while (std::getline(in, line)) {
    if (line.rfind("complete-level ", 0) == 0) return std::stoi(line.substr(15));
  }
  return -1;
}

TEST(MpiBuild, AnyRankCountGivesThePlainBuildsBytes) {
  PBDAM_REQUIRE_DATA(dem, test::dataDir() / "mars/megt90n000cb.lbl");
  test::TempDir dir;
  const ShellRun plain = runShell(buildArgs(dem, dir / "plain") + " --quiet");
  ASSERT_EQ(plain.exitCode, 0) << plain.err;
  EXPECT_EQ(plain.out.find("MPI ranks"), std::string::npos) << plain.out;
  for (int ranks : {1, 2, 3}) {
    const fs::path out = dir / ("np" + std::to_string(ranks));
    const ShellRun run = runShell(mpirun(ranks) + buildArgs(dem, out));
    ASSERT_EQ(run.exitCode, 0) << run.err;
    if (ranks > 1) {
      EXPECT_NE(run.out.find(std::to_string(ranks) + " MPI ranks"), std::string::npos) << run.out;
      // Rank 0 reports each level with every rank's share and throughput.
      EXPECT_NE(run.err.find("level 3: 48 blocks; rank 0 "), std::string::npos) << run.err;
      EXPECT_NE(run.err.find(", rank " + std::to_string(ranks - 1) + " "), std::string::npos)
          << run.err;
      EXPECT_NE(run.err.find("ETA"), std::string::npos) << run.err;
    }
    expectSameDataset(dir / "plain", out);
  }
  const ShellRun verify = runShell(std::string("'") + PBDAM_EXE + "' verify '" +
                                   (dir / "np3").string() + "' --dem '" + dem.string() + "'");
  EXPECT_EQ(verify.exitCode, 0) << verify.out << verify.err;
}

// A hybrid build under mpirun: ETOPO20 with the Luxembourg GeoTIFF joined to it (a sparse
// forest down to level 20 around it) gives the plain build's bytes on 2 ranks, and verifies
// against both sources.
TEST(MpiBuild, AnInsetBuildOnTwoRanksGivesThePlainBuildsBytes) {
  PBDAM_REQUIRE_DATA(dem, fs::path("/usr/share/ferret-vis/data/etopo20.cdf"));
  PBDAM_REQUIRE_DATA(lux, test::dataDir() / "geotiff/terra_elev_luxembourg.tif");
  test::TempDir dir;
  const auto args = [&](const fs::path& out) {
    return std::string("'") + PBDAM_EXE + "' build --dem '" + dem.string() +
           "' --planet earth --levels 4 --leaf-vertices 17 --min-patch-triangles 128 "
           "--texture-tile 64 --texture-format rgba8 --threads 1 --inset '" +
           lux.string() + "' --quiet --out '" + out.string() + "'";
  };
  const ShellRun plain = runShell(args(dir / "plain"));
  ASSERT_EQ(plain.exitCode, 0) << plain.err;
  const ShellRun two = runShell(mpirun(2) + args(dir / "np2"));
  ASSERT_EQ(two.exitCode, 0) << two.err;
  expectSameDataset(dir / "plain", dir / "np2");
  const ShellRun verify =
      runShell(std::string("'") + PBDAM_EXE + "' verify '" + (dir / "np2").string() + "' --dem '" +
               dem.string() + "' --inset '" + lux.string() + "' --quiet");
  EXPECT_EQ(verify.exitCode, 0) << verify.out << verify.err;
}

TEST(MpiBuild, AKilledRankStopsTheJobAndResumeCompletesIt) {
  PBDAM_REQUIRE_DATA(dem, test::dataDir() / "mars/megt90n000cb.lbl");
  test::TempDir dir;
  const ShellRun plain = runShell(buildArgs(dem, dir / "plain") + " --quiet");
  ASSERT_EQ(plain.exitCode, 0) << plain.err;

  // Rank 1 SIGKILLs itself when it starts level 3; rank 0 is then waiting in a collective.
  const fs::path out = dir / "killed";
  const ShellRun killed =
      runShell("PBDAM_TEST_FAIL_RANK=1 PBDAM_TEST_FAIL_LEVEL=3 PBDAM_TEST_FAIL_MODE=kill " +
               mpirun(2) + buildArgs(dem, out));
  EXPECT_NE(killed.exitCode, 0);
  EXPECT_LT(killed.seconds, 60.0) << "the job must stop, not hang";
  // mpirun names the dead rank; rank 0 names every rank's work item and the checkpoint.
  EXPECT_NE(killed.err.find("process rank 1"), std::string::npos) << killed.err;
  EXPECT_NE(killed.err.find("signal 9"), std::string::npos) << killed.err;
  EXPECT_NE(killed.err.find("during level 3 (rank 0: diamonds [0, 24), rank 1: diamonds [24, "
                            "48) of 48); checkpointed: levels 6..4"),
            std::string::npos)
      << killed.err;
  EXPECT_NE(killed.err.find("--resume"), std::string::npos) << killed.err;
  EXPECT_FALSE(fs::exists(out / "manifest.json"));
  EXPECT_EQ(completeLevel(out), 4);

  // Resuming with another rank count continues at level 3 and gives the same bytes.
  const ShellRun resumed = runShell(mpirun(3) + buildArgs(dem, out) + " --resume");
  ASSERT_EQ(resumed.exitCode, 0) << resumed.err;
  EXPECT_NE(resumed.out.find("resumed     after level 4"), std::string::npos) << resumed.out;
  EXPECT_EQ(resumed.err.find("level 4:"), std::string::npos) << "level 4 was rebuilt";
  EXPECT_NE(resumed.err.find("level 3:"), std::string::npos) << resumed.err;
  expectSameDataset(dir / "plain", out);
  const ShellRun verify = runShell(std::string("'") + PBDAM_EXE + "' verify '" + out.string() +
                                   "' --dem '" + dem.string() + "'");
  EXPECT_EQ(verify.exitCode, 0) << verify.out << verify.err;
}

/// The ranks mpirun started: its children, with their OMPI_COMM_WORLD_RANK.
pid_t rankPid(pid_t mpirunPid, int rank) {
  for (const auto& entry : fs::directory_iterator("/proc")) {
    const std::string name = entry.path().filename().string();
    if (name.find_first_not_of("0123456789") != std::string::npos) continue;
    std::ifstream stat(entry.path() / "stat");
    std::string pid, comm, state;
    long ppid = 0;
    if (!(stat >> pid >> comm >> state >> ppid) || ppid != mpirunPid) continue;
    const std::string environ = test::readFile(entry.path() / "environ");
    if (environ.find("OMPI_COMM_WORLD_RANK=" + std::to_string(rank) + '\0') != std::string::npos) {
      return static_cast<pid_t>(std::stol(pid));
    }
  }
  return -1;
}

TEST(MpiBuild, AnExternalKillDashNineOfARankStopsTheJob) {
  PBDAM_REQUIRE_DATA(dem, test::dataDir() / "mars/megt90n000cb.lbl");
  test::TempDir dir;
  const fs::path out = dir / "killed";
  const std::string errFile = (dir / "stderr.txt").string();
  const pid_t child = ::fork();
  ASSERT_GE(child, 0);
  if (child == 0) {
    // mpirun itself, so that its pid is known and its children are the ranks.
    const std::string command =
        "exec " + mpirun(2) + buildArgs(dem, out) + " 2>'" + errFile + "' >/dev/null";
    ::execl("/bin/sh", "sh", "-c", command.c_str(), static_cast<char*>(nullptr));
    ::_exit(127);
  }
  // Once the leaves are checkpointed, kill rank 1 the way an operator or the OOM killer would.
  const auto start = Clock::now();
  pid_t victim = -1;
  while (Clock::now() - start < std::chrono::seconds(60)) {
    if (completeLevel(out) >= 0 && completeLevel(out) <= 6) {
      victim = rankPid(child, 1);
      if (victim > 0) break;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  ASSERT_GT(victim, 0) << "rank 1 not found";
  ASSERT_EQ(::kill(victim, SIGKILL), 0);
  const auto killedAt = Clock::now();
  int status = 0;
  ASSERT_EQ(::waitpid(child, &status, 0), child);
  const double stopSeconds = std::chrono::duration<double>(Clock::now() - killedAt).count();
  EXPECT_LT(stopSeconds, 30.0) << "the job must stop, not hang";
  const std::string err = test::readFile(errFile);
  const bool finishedFirst = WIFEXITED(status) && WEXITSTATUS(status) == 0;
  if (finishedFirst) {
    // The kill was not tested at all: under CI that must show as a failure, not a quiet skip.
    const char* why =
        "the build finished before the kill of rank 1 landed, so the kill was not tested";
    if (test::runningInCi()) FAIL() << why << " (CI=true: not skipped)";
    GTEST_SKIP() << why;
  }
  EXPECT_NE(err.find("process rank 1"), std::string::npos) << err;
  EXPECT_NE(err.find("the job was stopped"), std::string::npos) << err;
  EXPECT_NE(err.find("rank 1: diamonds"), std::string::npos) << err;
  EXPECT_FALSE(fs::exists(out / "manifest.json"));

  const ShellRun plain = runShell(buildArgs(dem, dir / "plain") + " --quiet");
  ASSERT_EQ(plain.exitCode, 0) << plain.err;
  const ShellRun resumed = runShell(mpirun(2) + buildArgs(dem, out) + " --resume --quiet");
  ASSERT_EQ(resumed.exitCode, 0) << resumed.err;
  expectSameDataset(dir / "plain", out);
}

TEST(MpiBuild, ARankReportingAnErrorStopsTheJobNamingItsWorkItem) {
  PBDAM_REQUIRE_DATA(dem, test::dataDir() / "mars/megt90n000cb.lbl");
  test::TempDir dir;
  const ShellRun failed =
      runShell("PBDAM_TEST_FAIL_RANK=2 PBDAM_TEST_FAIL_LEVEL=5 PBDAM_TEST_FAIL_MODE=error " +
               mpirun(3) + buildArgs(dem, dir / "out"));
  EXPECT_NE(failed.exitCode, 0);
  EXPECT_LT(failed.seconds, 60.0);
  EXPECT_NE(failed.err.find("pbdam: rank 2 of 3 on "), std::string::npos) << failed.err;
  EXPECT_NE(failed.err.find("failed while building level 5 diamonds [128, 192) of 192: injected "
                            "failure"),
            std::string::npos)
      << failed.err;
  EXPECT_EQ(completeLevel(dir / "out"), 6);
}

TEST(MpiBuild, ARankFindingTheDiskFullStopsTheJobWithCode2AndResumeCompletesIt) {
  PBDAM_REQUIRE_DATA(dem, test::dataDir() / "mars/megt90n000cb.lbl");
  test::TempDir dir;
  const fs::path out = dir / "out";
  // Rank 1's level-4 nodes file finds no space (an injected ENOSPC, formats/FileWrite.h).
  const ShellRun full = runShell("PBDAM_TEST_FAIL_WRITE=level-04.part-1 " + mpirun(2) +
                                 buildArgs(dem, out) + " --quiet");
  EXPECT_EQ(full.exitCode, 2) << full.err;
  EXPECT_NE(full.err.find("pbdam: rank 1 of 2 on "), std::string::npos) << full.err;
  EXPECT_NE(full.err.find("level-04.part-1.nodes: no space to write "), std::string::npos)
      << full.err;
  EXPECT_NE(full.err.find("rerun with --resume"), std::string::npos) << full.err;
  EXPECT_FALSE(fs::exists(out / "manifest.json"));
  EXPECT_EQ(completeLevel(out), 5);
  const ShellRun resumed = runShell(mpirun(2) + buildArgs(dem, out) + " --resume --quiet");
  ASSERT_EQ(resumed.exitCode, 0) << resumed.err;
  const ShellRun plain = runShell(buildArgs(dem, dir / "plain") + " --quiet");
  ASSERT_EQ(plain.exitCode, 0) << plain.err;
  expectSameDataset(dir / "plain", out);
}

TEST(MpiBuild, ResumeRefusesACheckpointOfOtherOptions) {
  PBDAM_REQUIRE_DATA(dem, test::dataDir() / "mars/megt90n000cb.lbl");
  test::TempDir dir;
  const fs::path out = dir / "out";
  // One process: the injected error is returned as the build's failure (exit 1).
  const ShellRun failed = runShell(
      "PBDAM_TEST_FAIL_RANK=0 PBDAM_TEST_FAIL_LEVEL=4 "
      "PBDAM_TEST_FAIL_MODE=error " +
      buildArgs(dem, out) + " --quiet");
  EXPECT_EQ(failed.exitCode, 1) << failed.err;
  EXPECT_EQ(completeLevel(out), 5);
  for (const std::string& launcher : {std::string(), mpirun(2)}) {
    const ShellRun other = runShell(launcher + buildArgs(dem, out, 96) + " --resume");
    EXPECT_EQ(other.exitCode, 2) << other.err;
    EXPECT_NE(other.err.find("pbdam: --resume: "), std::string::npos) << other.err;
    EXPECT_NE(other.err.find("min-patch-triangles 128, this build 96"), std::string::npos)
        << other.err;
    // One line from pbdam (rank 0 only), whatever mpirun adds.
    std::size_t lines = 0;
    for (std::size_t at = other.err.find("pbdam: "); at != std::string::npos;
         at = other.err.find("pbdam: ", at + 1)) {
      ++lines;
    }
    EXPECT_EQ(lines, 1u) << other.err;
  }
  EXPECT_EQ(completeLevel(out), 5) << "a refused resume must keep the checkpoint";
  // The plain build resumes it too, to the bytes of an uninterrupted build.
  const ShellRun resumed = runShell(buildArgs(dem, out) + " --resume");
  ASSERT_EQ(resumed.exitCode, 0) << resumed.err;
  EXPECT_NE(resumed.err.find("resume: the checkpoint has levels 6..5"), std::string::npos)
      << resumed.err;
  const ShellRun plain = runShell(buildArgs(dem, dir / "plain") + " --quiet");
  ASSERT_EQ(plain.exitCode, 0) << plain.err;
  expectSameDataset(dir / "plain", out);
}

}  // namespace
}  // namespace pbdam::tools
