// MPI_COMM_WORLD as a Communicator: all_gather of byte strings of any length (MPI_Allgather
// of the lengths, then MPI_Allgatherv). Only the main thread calls MPI (MPI_THREAD_FUNNELED).
#include "mpi_processes.hpp"

#include <fmt/format.h>

#include <cstdlib>
#include <string>

#include "btfgmm/core/error.hpp"

#if defined(BTFGMM_HAVE_MPI)
#include <mpi.h>
#endif

namespace btfgmm::cli {
namespace {

int environment_int(const char* name) {
  const char* v = std::getenv(name);
  return v ? std::atoi(v) : -1;
}

// The job size the launcher announces (OpenMPI, MPICH/Hydra, PMIx, Slurm), -1 if none.
int launcher_size() {
  for (const char* name : {"OMPI_COMM_WORLD_SIZE", "PMI_SIZE", "PMIX_SIZE", "SLURM_NTASKS"})
    if (const int n = environment_int(name); n > 0) return n;
  return -1;
}

#if defined(BTFGMM_HAVE_MPI)
void check_mpi(int status, const char* call) {
  if (status == MPI_SUCCESS) return;
  char text[MPI_MAX_ERROR_STRING];
  int length = 0;
  MPI_Error_string(status, text, &length);
  throw Error(Error::Kind::kIo, fmt::format("{} failed between the processes of the job: {}; "
                                            "check that every process is still running",
                                            call, std::string(text, std::size_t(length))));
}

class MpiCommunicator final : public Communicator {
 public:
  MpiCommunicator() {
    int provided = 0;
    check_mpi(MPI_Init_thread(nullptr, nullptr, MPI_THREAD_FUNNELED, &provided), "MPI_Init");
    std::atexit([] {
      int finalized = 0;
      MPI_Finalized(&finalized);
      if (!finalized) MPI_Finalize();
    });
    MPI_Comm_set_errhandler(MPI_COMM_WORLD, MPI_ERRORS_RETURN);
    MPI_Comm_rank(MPI_COMM_WORLD, &rank_);
    MPI_Comm_size(MPI_COMM_WORLD, &size_);
  }
  int rank() const override { return rank_; }
  int size() const override { return size_; }
  std::uint64_t bytes_exchanged() const override { return bytes_; }

  std::vector<std::vector<std::uint8_t>> all_gather(std::span<const std::uint8_t> mine) override {
    const auto n = static_cast<long long>(mine.size());
    std::vector<long long> lengths(static_cast<std::size_t>(size_));
    check_mpi(MPI_Allgather(&n, 1, MPI_LONG_LONG, lengths.data(), 1, MPI_LONG_LONG, MPI_COMM_WORLD),
              "MPI_Allgather");
    std::vector<int> counts(static_cast<std::size_t>(size_)),
        offsets(static_cast<std::size_t>(size_));
    long long total = 0;
    for (std::size_t r = 0; r < lengths.size(); ++r) {
      if (total + lengths[r] > (1LL << 31) - 1)
        throw Error(Error::Kind::kArgument,
                    "a distributed fit exchanged more than 2 GB at once; use fewer components "
                    "or more processes");
      offsets[r] = int(total);
      counts[r] = int(lengths[r]);
      total += lengths[r];
    }
    std::vector<std::uint8_t> all(static_cast<std::size_t>(total));
    check_mpi(MPI_Allgatherv(mine.data(), int(n), MPI_BYTE, all.data(), counts.data(),
                             offsets.data(), MPI_BYTE, MPI_COMM_WORLD),
              "MPI_Allgatherv");
    bytes_ += std::uint64_t(n) + std::uint64_t(total - n);
    std::vector<std::vector<std::uint8_t>> out(static_cast<std::size_t>(size_));
    for (std::size_t r = 0; r < out.size(); ++r)
      out[r].assign(all.begin() + offsets[r], all.begin() + offsets[r] + counts[r]);
    return out;
  }

 private:
  int rank_ = 0, size_ = 1;
  std::uint64_t bytes_ = 0;
};

bool mpi_running() {
  int initialized = 0, finalized = 0;
  MPI_Initialized(&initialized);
  MPI_Finalized(&finalized);
  return initialized && !finalized;
}
#endif

}  // namespace

bool started_by_mpi_launcher() {
  return launcher_size() > 0;
}

std::shared_ptr<Communicator> job_processes() {
  if (!started_by_mpi_launcher()) return nullptr;
#if defined(BTFGMM_HAVE_MPI)
  return std::make_shared<MpiCommunicator>();
#else
  if (launcher_size() > 1)
    throw Error(Error::Kind::kArgument,
                fmt::format("started as one of {} processes (mpirun), but this btfgmm was built "
                            "without MPI; build it with the MPI packages present "
                            "(scripts/install-deps, cmake -DBTFGMM_MPI=ON) or run it alone",
                            launcher_size()));
  return nullptr;
#endif
}

void end_job_on_error(int status) {
#if defined(BTFGMM_HAVE_MPI)
  if (mpi_running()) MPI_Abort(MPI_COMM_WORLD, status);
#else
  (void)status;
#endif
}

}  // namespace btfgmm::cli
