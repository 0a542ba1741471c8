#pragma once

#include <deal.II/lac/trilinos_precondition.h>
#include <deal.II/lac/trilinos_sparse_matrix.h>
#include <deal.II/lac/trilinos_vector.h>

#include <vi/parameters.h>

#include <memory>

class Amesos_BaseSolver;
class Epetra_LinearProblem;

namespace VI
{
  /// What an iterative solve did.
  struct LinearSolveReport
  {
    enum class Outcome
    {
      converged,         ///< |b - A x| <= tolerance
      stopped_by_caller, ///< the monitor asked to stop (adaptive stopping)
      stagnated, ///< the recurrence met the tolerance, the true residual
                 ///< stayed above it: the rounding level of the system
    };
    Outcome      outcome          = Outcome::converged;
    unsigned int iterations       = 0;
    double       initial_residual = 0.; ///< |b - A x0|
    double       final_residual   = 0.; ///< |b - A x| (recurrence estimate)
  };


  /**
   * Restarted GMRES with right preconditioning, which minimises the true
   * residual |b - A x| over the Krylov space, and which hands its *current*
   * iterate x^i = x0 + P^{-1} V y^i to a monitor every `check_interval`
   * iterations. That is what estimator-based stopping criteria need: the
   * estimators of the iterate the solver would return if it stopped now.
   * (deal.II 9.4's SolverGMRES only exposes the iterate of the start of the
   * current restart cycle; solving in chunks of nu iterations would restart
   * GMRES every nu iterations and slow it down.) Computing the current
   * iterate costs one preconditioner application per check.
   *
   * The operator and the preconditioner are functions dst = A src and
   * dst = P^{-1} src, so any matrix (Trilinos, deal.II, matrix-free) and any
   * preconditioner can be used.
   */
  template <typename VectorType>
  class Gmres
  {
  public:
    using Operator =
      std::function<void(VectorType &dst, const VectorType &src)>;
    /// Called with the current iterate and the iteration count i; returns
    /// true to stop with that iterate.
    using Monitor = std::function<bool(const VectorType &x, unsigned int i)>;
    /// Called at every iteration i with GMRES's residual |b - A x^i| (which
    /// the recurrence gives at no cost) and the initial one |b - A x^0|;
    /// returns true to hand x^i to the monitor now, besides every
    /// check_interval iterations.
    using Schedule = std::function<
      bool(unsigned int i, double residual, double initial_residual)>;

    struct AdditionalData
    {
      unsigned int max_iterations     = 1000;
      unsigned int krylov_dimension   = 100;   ///< restart length
      double       relative_tolerance = 1e-12; ///< on |b - A x| / |b - A x0|
      double       absolute_tolerance = 0.;
      /// nu: the monitor sees at least every nu-th iterate
      unsigned int check_interval = 10;
    };

    explicit Gmres(const AdditionalData &data);

    /**
     * Solve A x = b from the initial guess x. Throws SolverFailure if the
     * tolerance is not reached within max_iterations (unless the monitor
     * stopped the iteration). The monitor sees the iterate check_interval
     * iterations after its last check, or earlier where `schedule` asks.
     */
    LinearSolveReport
    solve(const Operator   &A,
          const Operator   &preconditioner,
          VectorType       &x,
          const VectorType &b,
          const Monitor    &monitor  = {},
          const Schedule   &schedule = {}) const;

  private:
    AdditionalData data;
  };


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


  /**
   * The suite's Trilinos ML settings for the Laplacians of the membranes
   * (elliptic, two smoother sweeps, aggregation threshold 0.02): used by the
   * contact preconditioner, the reference Poisson solve of the cost
   * benchmark and DualNormBound.
   */
  dealii::TrilinosWrappers::PreconditionAMG::AdditionalData
  elliptic_amg_settings(const bool higher_order_elements);
} // namespace VI
