// Loading the MPI module when mpirun started `pbdam` (MpiLauncher.h).
#include "MpiLauncher.h"

#include <dlfcn.h>
#include <unistd.h>

#include <array>
#include <cstdlib>
#include <cstring>
#include <filesystem>

#include "pbdam/formats/Module.h"

using namespace pbdam::formats;

namespace pbdam::tools {

bool launchedByMpi() noexcept {
  for (const char* name : {"OMPI_COMM_WORLD_SIZE", "PMIX_RANK", "PMI_SIZE"}) {
    const char* v = std::getenv(name);
    if (v != nullptr && *v != '\0') return true;
  }
  return false;
}

bool isMpiRankOtherThanZero() noexcept {
  for (const char* name : {"OMPI_COMM_WORLD_RANK", "PMIX_RANK", "PMI_RANK"}) {
    const char* v = std::getenv(name);
    if (v != nullptr && *v != '\0') return std::strcmp(v, "0") != 0;
  }
  return false;
}

Result<std::unique_ptr<MpiJob>> joinMpiJob() {
#ifndef PBDAM_WITH_MPI
  return makeError(ErrorCode::UnsupportedFormat,
                   "started by an MPI launcher, but this pbdam was built without MPI "
                   "(configure with -DPBDAM_WITH_MPI=ON)");
#else
  // RTLD_GLOBAL: OpenMPI's own plugins resolve libmpi/libopen-pal symbols through it.
  const Result<void*> opened =
      formats::openModule("libpbdam_mpi.so", PBDAM_MPI_MODULE, RTLD_NOW | RTLD_GLOBAL);
  if (!opened) {
    return makeError(ErrorCode::NotFound,
                     "started by an MPI launcher, but the MPI module could not be loaded (" +
                         opened.error().message + "; is OpenMPI installed?)");
  }
  void* module = *opened;
  using Connect = builder::Communicator* (*)(char*, std::size_t);
  using Disconnect = void (*)(builder::Communicator*);
  auto connect = reinterpret_cast<Connect>(::dlsym(module, "pbdam_mpi_connect"));
  auto disconnect = reinterpret_cast<Disconnect>(::dlsym(module, "pbdam_mpi_disconnect"));
  if (connect == nullptr || disconnect == nullptr) {
    return makeError(ErrorCode::NotFound, "libpbdam_mpi.so lacks its entry points");
  }
  std::array<char, 256> error{};
  auto job = std::make_unique<MpiJob>();
  job->communicator = connect(error.data(), error.size());
  if (job->communicator == nullptr) {
    return makeError(ErrorCode::Internal, std::string("MPI: ") + error.data());
  }
  job->disconnect = disconnect;
  return job;  // the module stays loaded until the process exits
#endif
}

}  // namespace pbdam::tools
