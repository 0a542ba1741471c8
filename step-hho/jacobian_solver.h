#pragma once

#include <deal.II/lac/trilinos_precondition.h>
#include <deal.II/lac/trilinos_sparse_matrix.h>
#include <deal.II/lac/trilinos_vector.h>

#include <vi/linear_solvers.h>
#include <vi/parameters.h>

#include <functional>
#include <memory>
#include <vector>

namespace StepHHO
{
  using namespace dealii;

  /// Asked every `interval` CG iterations (and before the first) with the
  /// iterate x: true to stop CG there.
  struct CGWatch
  {
    std::function<bool(const TrilinosWrappers::MPI::Vector &x)> stop;
    unsigned int                                                interval = 1;
  };


  /**
   * The solver of one linear system of a Newton step (the whole Jacobian, or
   * one of the two face systems of the static condensation): sparse LU (VI::
   * LinearSolver: symbolic factorisation once per matrix, numeric one per
   * initialize()), or CG preconditioned with AMG or ILU for the face systems
   * of the static condensation, which are symmetric positive definite (the
   * energy of the cell problems with their constraints eliminated).
   * (initialize() and solve() are defined in hho_solver.cc.)
   */
  class JacobianSolver
  {
  public:
    JacobianSolver(const VI::LinearSolverParameters     &parameters,
                   const std::vector<std::vector<bool>> &constant_modes,
                   const bool                            higher_order)
        : parameters(parameters)
        , direct(parameters)
        , constant_modes(constant_modes)
        , higher_order(higher_order)
    {
    }

    void
    initialize(const TrilinosWrappers::SparseMatrix &A);

    /**
     * Solve A x = b, by CG to |b - A x| <= tolerance or until `watch` stops
     * it; return the number of CG iterations (0 for LU).
     */
    unsigned int
    solve(const TrilinosWrappers::SparseMatrix &A,
          TrilinosWrappers::MPI::Vector        &x,
          const TrilinosWrappers::MPI::Vector  &b,
          const double                          tolerance,
          const CGWatch                        &watch = {});

  private:
    const VI::LinearSolverParameters                    parameters;
    VI::LinearSolver                                    direct;
    std::unique_ptr<TrilinosWrappers::PreconditionBase> preconditioner;
    const std::vector<std::vector<bool>>                constant_modes;
    const bool                                          higher_order;
  };
} // namespace StepHHO
