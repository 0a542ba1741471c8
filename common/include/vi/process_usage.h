#pragma once

#include <mpi.h>

namespace VI
{
  /**
   * What the processes of a communicator have cost the machine so far, from
   * getrusage(RUSAGE_SELF), summed over the processes (and, within each, over
   * its threads): CPU seconds in the program and in the kernel, and minor page
   * faults. The difference of two readings tells how much of a phase's wall
   * time the kernel took, mostly the first touch of memory: on a virtual
   * machine whose host takes back freed memory (free page reporting), every
   * page touched for the first time costs a fault on the host as well, and
   * the first solve on a mesh larger than any before pays for all of it
   * (doc/performance.md, "Where the time above linear goes").
   */
  struct ProcessUsage
  {
    double user_seconds   = 0; ///< CPU time in the program
    double system_seconds = 0; ///< CPU time in the kernel
    double minor_faults   = 0; ///< page faults served without I/O

    /// The reading now, summed over the processes. Collective.
    static ProcessUsage
    now(const MPI_Comm comm);

    /// What was spent between `earlier` and this reading.
    ProcessUsage
    operator-(const ProcessUsage &earlier) const;
  };

  /// The largest resident memory each process of `comm` has had so far
  /// (getrusage's ru_maxrss), summed over the processes: at most what the
  /// run has needed of the machine at once. Collective.
  double
  peak_resident_bytes(const MPI_Comm comm);
} // namespace VI
