// The error policy of every Fabrica executable under MPI:
//   - InputError and CollectiveError are met identically by every rank (the scene is parsed
//     and validated on every rank; collective errors come from reduced values): rank 0 prints
//     the message once and every rank returns 1;
//   - any other exception may be met by one rank only while the others wait in a collective:
//     that rank prints its message with its rank and calls MPI_Abort, which ends every rank
//     with a non-zero exit. Nothing hangs.
#pragma once
#include "parallel/mpi_context.hpp"

#include <functional>

namespace fabrica {

int run_guarded(const MpiContext& mpi, const std::function<int()>& body);

}  // namespace fabrica
