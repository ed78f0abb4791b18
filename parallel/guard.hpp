// The error policy of every Fabrica executable under MPI (docs/parallel.md):
//   - an error met by every rank (InputError and CollectiveError from agreed or reduced values,
//     or any error that agree() below has made common): rank 0 prints the message once and every
//     rank returns 1;
//   - an error met by some ranks only, while the others wait in a collective or go on: each rank
//     that met it waits a few seconds (FABRICA_ERROR_WAIT, default 5 s) for the others on a
//     communicator of the guard's own; if they do not all arrive, it prints its message with its
//     rank and calls MPI_Abort, which ends every rank with a non-zero exit. Nothing hangs.
// SIGXFSZ (a file-size limit, ulimit -f) is ignored, so that a write beyond the limit fails
// with EFBIG and is reported like a full disk instead of killing the process without a word.
#pragma once
#include "parallel/mpi_context.hpp"

#include <functional>
#include <string>

namespace fabrica {

int run_guarded(const MpiContext& mpi, const std::function<int()>& body);

// Runs 'phase' on every rank of 'comm' (collective) and agrees on its outcome: if it threw on
// any rank, every rank throws the error of the lowest such rank - an InputError if that was one,
// a CollectiveError otherwise. For rank-local work (each rank reading a file, rank 0 writing
// one) followed by collective work.
void agree(MPI_Comm comm, const std::function<void()>& phase);

// Called when a file of a library that closes its files at MPI_Finalize (HDF5) was abandoned
// after a failed write: HDF5 1.10 crashes closing such a file. run_guarded then ends the
// process after the error message with exit status 1 without MPI_Finalize.
void exit_without_finalize_on_error();

}  // namespace fabrica
