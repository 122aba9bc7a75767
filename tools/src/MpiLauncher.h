// Joining the MPI job when `pbdam` was started by mpirun (docs/builder.md "Distributed build"):
// the launcher's environment says so; only then is the MPI module (libpbdam_mpi.so) loaded with
// dlopen and MPI initialised, so a plain `pbdam` never touches MPI. Thread-safety: call from the
// main thread.
#pragma once

#include <memory>
#include <string>

#include "pbdam/builder/Communicator.h"
#include "pbdam/formats/Result.h"

namespace pbdam::tools {

/// True when an MPI launcher (OpenMPI's mpirun/mpiexec, or a PMIx/PMI one) started this process.
bool launchedByMpi() noexcept;
/// True when an MPI launcher started this process as a rank other than 0 (which then keeps
/// quiet about errors every rank finds alike, such as bad options).
bool isMpiRankOtherThanZero() noexcept;

/// The world communicator of the job, owned: destroying it finalises MPI. Errors: this pbdam
/// was built without MPI (PBDAM_WITH_MPI=OFF), the module or the MPI library cannot be loaded,
/// or MPI fails to initialise.
struct MpiJob final {
  builder::Communicator* communicator = nullptr;
  void (*disconnect)(builder::Communicator*) = nullptr;
  MpiJob() = default;
  MpiJob(const MpiJob&) = delete;
  MpiJob& operator=(const MpiJob&) = delete;
  ~MpiJob() {
    if (communicator != nullptr && disconnect != nullptr) disconnect(communicator);
  }
};
formats::Result<std::unique_ptr<MpiJob>> joinMpiJob();

}  // namespace pbdam::tools
