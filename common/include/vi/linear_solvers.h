#pragma once

#include <deal.II/lac/trilinos_sparse_matrix.h>
#include <deal.II/lac/trilinos_vector.h>
#include <memory>
#include <vi/parameters.h>

class Amesos_BaseSolver;
class Epetra_LinearProblem;

namespace VI
{
  /**
   * Solver of the linearised semismooth Newton systems A dX = b.
   *
   * "direct": sparse LU through Trilinos Amesos, MUMPS (distributed) or KLU
   * (on rank 0). Along a Newton iteration the sparsity pattern of A is fixed
   * and only the complementarity rows change, so the symbolic factorisation
   * is computed once per matrix and only the numeric one per Newton step.
   * MUMPS gets extra workspace (and more on a retry): pivoting on the zero
   * diagonals of the contact rows needs more than its a priori estimate.
   */
  class LinearSolver
  {
  public:
    explicit LinearSolver(const LinearSolverParameters &parameters);
    ~LinearSolver();

    /**
     * Factorise A. The first call for a given matrix also computes the
     * symbolic factorisation; later calls with the same matrix (same
     * pattern, new values) only the numeric one. A must stay alive.
     */
    void
    initialize(const dealii::TrilinosWrappers::SparseMatrix &A);

    /**
     * Solve A x = b with the matrix of the last initialize(); return the
     * number of iterations (0 for a direct solve). Throws SolverFailure.
     */
    unsigned int
    solve(const dealii::TrilinosWrappers::MPI::Vector &b,
          dealii::TrilinosWrappers::MPI::Vector       &x);

  private:
    const LinearSolverParameters                  parameters;
    const dealii::TrilinosWrappers::SparseMatrix *matrix = nullptr;
    std::unique_ptr<Epetra_LinearProblem>         problem;
    std::unique_ptr<Amesos_BaseSolver>            direct;
    int                                           mumps_extra_workspace = 100;
  };
} // namespace VI
