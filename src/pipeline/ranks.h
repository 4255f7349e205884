/// @file ranks.h
/// @brief The processes of one `aoscan scans` run: a single process, or the ranks of an MPI job
/// (`mpirun -np N aoscan scans ...`) sharing the scratch folder. Only what the scan-set job needs:
/// who am I, wait for the others, add up counts, end the job.
#pragma once

#include <memory>

namespace aoscan {

class Ranks {
 public:
  virtual ~Ranks() = default;
  virtual int rank() const = 0;
  virtual int size() const = 0;
  /// Ranks started on this machine (for the default thread count).
  virtual int local_size() const = 0;
  /// Returns once every rank has called it.
  virtual void barrier() = 0;
  /// The sum over all ranks (every rank gets it).
  virtual long long sum(long long value) = 0;
  /// Ends every rank of the job with `exit_code` (after this rank printed why): the others may be
  /// waiting at a barrier for it.
  [[noreturn]] virtual void abort(int exit_code) = 0;
};

/// One process: rank 0 of 1.
std::unique_ptr<Ranks> single_process();

/// The ranks of the MPI job this process was started in (MPI initialised here, finalised when the
/// object goes), or single_process() when it was not started by an MPI launcher or aoscan was
/// built without MPI. Throws usage_error when started by mpirun but built without MPI with more
/// than one rank (each would do the whole job).
std::unique_ptr<Ranks> open_ranks();

/// True when aoscan was built with MPI.
bool built_with_mpi();

}  // namespace aoscan
