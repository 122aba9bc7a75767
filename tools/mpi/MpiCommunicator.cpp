// The Communicator of `mpirun -np N pbdam build` on MPI (Debian's OpenMPI; docs/builder.md
// "Distributed build"). Built as a module (libpbdam_mpi.so) that `pbdam` loads with dlopen only
// when an MPI launcher started it, so a plain `pbdam` needs no MPI library at run time. MPI is
// initialised with MPI_THREAD_FUNNELED: only the build thread calls MPI; TBB workers never do.
// Errors of MPI calls keep MPI's default handler (MPI_ERRORS_ARE_FATAL): they abort the job.
#include <mpi.h>

#include <algorithm>
#include <cstdint>
#include <cstdio>
#include <limits>
#include <string>

#include "pbdam/builder/Communicator.h"

namespace {

using pbdam::builder::Communicator;

/// MPI counts are ints: larger buffers go in pieces of at most this many bytes.
constexpr std::size_t kPieceBytes = std::size_t{1} << 30;

int pieceOf(std::size_t remaining) { return static_cast<int>(std::min(remaining, kPieceBytes)); }

class MpiCommunicator final : public Communicator {
 public:
  MpiCommunicator() {
    MPI_Comm_rank(MPI_COMM_WORLD, &rank_);
    MPI_Comm_size(MPI_COMM_WORLD, &size_);
  }
  ~MpiCommunicator() override { MPI_Finalize(); }

  int rank() const noexcept override { return rank_; }
  int size() const noexcept override { return size_; }
  std::string hostName() const override {
    char name[MPI_MAX_PROCESSOR_NAME] = {};
    int length = 0;
    MPI_Get_processor_name(name, &length);
    return std::string(name, static_cast<std::size_t>(length));
  }

  std::vector<std::vector<std::byte>> allGather(std::vector<std::byte> mine) override {
    const auto sizes = allSizes(mine.size());
    std::vector<std::vector<std::byte>> all(static_cast<std::size_t>(size_));
    all[static_cast<std::size_t>(rank_)] = std::move(mine);
    for (int r = 0; r < size_; ++r) {
      auto& bytes = all[static_cast<std::size_t>(r)];
      if (r != rank_) bytes.resize(sizes[static_cast<std::size_t>(r)]);
      broadcastFrom(r, bytes);
    }
    return all;
  }

  void broadcast(std::vector<std::byte>& bytes) override {
    std::uint64_t size = bytes.size();
    MPI_Bcast(&size, 1, MPI_UINT64_T, 0, MPI_COMM_WORLD);
    bytes.resize(size);
    broadcastFrom(0, bytes);
  }

  [[noreturn]] void abortJob(int exitCode) override {
    MPI_Abort(MPI_COMM_WORLD, exitCode);
    std::_Exit(exitCode);  // MPI_Abort does not return; this is for the compiler
  }

 private:
  std::vector<std::uint64_t> allSizes(std::size_t mine) const {
    std::uint64_t size = mine;
    std::vector<std::uint64_t> sizes(static_cast<std::size_t>(size_));
    MPI_Allgather(&size, 1, MPI_UINT64_T, sizes.data(), 1, MPI_UINT64_T, MPI_COMM_WORLD);
    return sizes;
  }

  static void broadcastFrom(int root, std::vector<std::byte>& bytes) {
    for (std::size_t at = 0; at < bytes.size(); at += kPieceBytes) {
      MPI_Bcast(bytes.data() + at, pieceOf(bytes.size() - at), MPI_BYTE, root, MPI_COMM_WORLD);
    }
  }

  int rank_ = 0;
  int size_ = 1;
};

}  // namespace

/// The module's entry points, looked up by `pbdam` with dlsym (tools/src/MpiLauncher.cpp).
/// pbdam_mpi_connect initialises MPI and returns the world communicator, or null with a message
/// in `error` (of `errorBytes`) when MPI cannot start. pbdam_mpi_disconnect finalises it.
extern "C" __attribute__((visibility("default"))) Communicator* pbdam_mpi_connect(
    char* error, std::size_t errorBytes) {
  int provided = 0;
  if (MPI_Init_thread(nullptr, nullptr, MPI_THREAD_FUNNELED, &provided) != MPI_SUCCESS) {
    std::snprintf(error, errorBytes, "MPI_Init_thread failed");
    return nullptr;
  }
  if (provided < MPI_THREAD_FUNNELED) {
    std::snprintf(error, errorBytes, "the MPI library does not support MPI_THREAD_FUNNELED");
    MPI_Finalize();
    return nullptr;
  }
  return new MpiCommunicator();  // NOLINT: ownership passes to pbdam_mpi_disconnect
}

extern "C" __attribute__((visibility("default"))) void pbdam_mpi_disconnect(
    Communicator* communicator) {
  delete communicator;  // NOLINT: created by pbdam_mpi_connect
}
