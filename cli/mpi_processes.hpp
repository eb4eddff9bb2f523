// The processes of an MPI job (mpirun) as the library's Communicator
// (btfgmm/core/communicator.hpp). The MPI part is compiled only where the build found MPI
// (option BTFGMM_MPI; the macro BTFGMM_HAVE_MPI is then defined).
#pragma once

#include <cstdint>
#include <memory>
#include <span>
#include <vector>

#include "btfgmm/core/communicator.hpp"

namespace btfgmm::cli {

// Whether this process was started by an MPI launcher (mpirun, mpiexec, srun): its
// environment names a rank and a job size.
bool started_by_mpi_launcher();

// The processes of this job: MPI's when started by a launcher in a build with MPI (null
// otherwise: the fit runs in this process alone). Throws Error(kArgument) when started by a
// launcher in a build without MPI and the job has more than one process.
std::shared_ptr<Communicator> job_processes();

// Ends every process of the job with `status` (after this one has reported an error, so that
// the others do not wait for it for ever); returns where there is no job.
void end_job_on_error(int status);

}  // namespace btfgmm::cli
