// The processes of a build and the few collective operations the distributed build needs
// ([P-BDAM 2003] §5 "independent simplify" between per-level synchronisations; docs/builder.md
// "Distributed build"). One process is the LocalCommunicator; `mpirun -np N pbdam build` gets an
// MPI implementation (tools/mpi). The builder only ever exchanges small opaque byte buffers
// (outcomes, per-level statistics; the bulk data goes through shared files), so it does not
// depend on MPI. Thread-safety: call from the thread that runs the build only.
#pragma once

#include <cstddef>
#include <string>
#include <vector>

namespace pbdam::builder {

class Communicator {
 public:
  virtual ~Communicator() = default;
  Communicator() = default;
  Communicator(const Communicator&) = delete;
  Communicator& operator=(const Communicator&) = delete;

  /// This process's rank in [0, size()). Rank 0 writes the output and reports progress.
  virtual int rank() const noexcept = 0;
  virtual int size() const noexcept = 0;
  /// The host this rank runs on (for messages).
  virtual std::string hostName() const = 0;

  /// Collective: every rank's bytes, in rank order, on every rank (this rank's own buffer is
  /// moved into its slot, not copied). Any size (buffers over 1 GiB are sent in pieces).
  virtual std::vector<std::vector<std::byte>> allGather(std::vector<std::byte> mine) = 0;
  /// Collective: rank 0's `bytes` replace every other rank's.
  virtual void broadcast(std::vector<std::byte>& bytes) = 0;
  /// Stops every process of the job with `exitCode`; the caller has printed why. With more
  /// than one rank this is the only way to fail after the ranks agreed to start: a rank that
  /// just returned would leave the others waiting in the next collective.
  [[noreturn]] virtual void abortJob(int exitCode) = 0;
};

/// The one-process build: collectives are copies.
class LocalCommunicator final : public Communicator {
 public:
  int rank() const noexcept override { return 0; }
  int size() const noexcept override { return 1; }
  std::string hostName() const override;
  std::vector<std::vector<std::byte>> allGather(std::vector<std::byte> mine) override {
    std::vector<std::vector<std::byte>> all(1);
    all[0] = std::move(mine);
    return all;
  }
  void broadcast(std::vector<std::byte>&) override {}
  [[noreturn]] void abortJob(int exitCode) override;
};

}  // namespace pbdam::builder
