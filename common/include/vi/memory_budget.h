#pragma once

#include <mpi.h>
#include <string>

namespace VI
{
  struct DomainParameters;
  struct MeshParameters;
  struct DiscretizationParameters;
  struct LinearSolverParameters;

  /**
   * What a run of a stationary membrane program will need, known from its
   * parameters before a mesh or a system is built, and what the machine
   * can give it.
   *
   * The need is a measured model: a base of every process (libraries, MPI)
   * plus a cost per unknown of the largest mesh, measured for each method
   * and linear solver with the default estimators (bench/memory_model.py,
   * doc/data/memory-model.md): a direct solver's factors or GMRES's
   * Krylov basis under ILU cost two to three times what an AMG-
   * preconditioned solve does. The largest mesh is the last of a globally
   * refined sequence, or the first one with adaptive refinement (whose growth
   * is not known in advance), or the one mesh of a time-dependent run. The
   * machine gives the smaller of the node's MemAvailable and the limit of the
   * process's cgroup less its usage.
   */
  struct MemoryBudget
  {
    /// The budget of a run with these sections on the ranks of `comm`
    /// (collective: rank 0 reads the machine's limits).
    MemoryBudget(const MeshParameters           &mesh,
                 const DiscretizationParameters &discretization,
                 const LinearSolverParameters   &linear_solver,
                 const MPI_Comm                  comm);
    /// The same for a run on one mesh (step-parabolic, charged as a
    /// stationary run with a direct solver: its ring test measured less).
    MemoryBudget(const DomainParameters         &mesh,
                 const DiscretizationParameters &discretization,
                 const MPI_Comm                  comm);

    /**
     * The same for a run whose size is known by its caller: `unknowns` on
     * `cells` cells, each unknown costing `bytes_per_unknown` beyond the
     * base of a process (step-twophase, whose 1D mesh is its "Number of
     * cells"); `to_lower` names the parameter that makes the run smaller.
     */
    MemoryBudget(const double       cells,
                 const double       unknowns,
                 const double       bytes_per_unknown,
                 const std::string &to_lower,
                 const MPI_Comm     comm);

    /// Throws InputError, one line with both numbers and the parameters to
    /// lower, if the run cannot fit.
    void
    check() const;

    /// Cells and unknowns of the largest mesh.
    double cells    = 0;
    double unknowns = 0;
    /// Bytes the run needs, and bytes available on the node.
    double needed    = 0;
    double available = 0;
    /// The parameters that make the largest mesh smaller.
    std::string to_lower = "Mesh/Initial refinements";

  private:
    /// The budget of `levels` refinements of the coarse mesh of `mesh`,
    /// each unknown costing what bytes_per_unknown() says of the
    /// discretisation and the linear solver (nullptr: a direct one).
    MemoryBudget(const DomainParameters         &mesh,
                 const unsigned int              levels,
                 const DiscretizationParameters &discretization,
                 const LinearSolverParameters   *linear_solver,
                 const MPI_Comm                  comm);

    /// needed and available for the cells and unknowns already set.
    void
    compare_with_machine(const double bytes_per_unknown, const MPI_Comm comm);
  };
} // namespace VI
