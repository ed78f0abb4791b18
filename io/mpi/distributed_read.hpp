// A LAMMPS data file read by the ranks of a communicator together (a step of the distributed
// set-up, io/mpi/distributed_setup.hpp): each rank reads the header and then only its byte
// range of the body; every line is checked where it is read, and the whole-file checks (each id
// once, every velocity for an atom, the counts) are made through a directory: the rank id mod P
// receives the atoms and velocities of the ids it is responsible for, and keeps them. Every
// error is the serial reader's message (io/serial/lammps_data.hpp), met by every rank.
#pragma once
#include "io/serial/lammps_data.hpp"

#include <mpi.h>

#include <cstdint>
#include <string>
#include <vector>

namespace fabrica {

// Collective over 'comm'. The particles returned are this rank's part of the file (by id).
DataFile read_data_share(const std::string& path, MPI_Comm comm, const std::vector<std::int64_t>* types);

// The ranks of 'comm' on this machine (collective).
int ranks_on_this_node(MPI_Comm comm);

}  // namespace fabrica
