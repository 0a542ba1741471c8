#pragma once

#include <deal.II/base/index_set.h>
#include <deal.II/lac/affine_constraints.h>
#include <deal.II/lac/trilinos_sparse_matrix.h>
#include <deal.II/lac/trilinos_vector.h>

#include <vi/contact_rows.h>
#include <vi/linear_solvers.h>
#include <vi/semismooth_newton.h>

#include <functional>
#include <memory>
#include <vector>

namespace dealii
{
  class ConditionalOStream;
  class DynamicSparsityPattern;
  class TimerOutput;
  namespace TrilinosWrappers
  {
    class PreconditionILU;
  }
} // namespace dealii

namespace VI
{
  class ComplementarityFunction;
  class ContactPreconditioner;
  struct LinearSolverParameters;
  struct NonlinearSolverParameters;

  /**
   * The algebraic side of the two-membrane contact problems, shared by every
   * discretisation that writes them in node-interleaved unknowns X = (X1, X2,
   * X3) (NodalFields): conforming Q_p, interior penalty dG and the
   * time-dependent problem. It holds
   *
   * - the matrix A = [E ; J_C], whose balance rows E the program assembles
   *   and whose complementarity rows J_C are rewritten at every Newton step,
   *   and the load F;
   * - the coupling -D / +D of the multiplier in the rows of u1 / u2, the
   *   contact rows (ContactRows) and their weights in force units;
   * - the solver of A dX = b: sparse LU, or GMRES with ILU or the contact
   *   AMG preconditioner, with an optional monitor (estimator-based
   *   stopping, see AdaptiveStopping);
   *
   * and plugs all of this into a SemismoothNewton (attach()). A program
   * calls reinit() once per mesh, assembles E and F into `matrix` and
   * `rhs`, then calls set_coupling() and set_stiffness_weights().
   */
  class ContactSystem
  {
  public:
    using Vector = dealii::TrilinosWrappers::MPI::Vector;

    /// The timer gets the sections "newton: residual", "newton: jacobian",
    /// "newton: preconditioner" and "newton: linear solve".
    ContactSystem(const ComplementarityFunction   &C,
                  const NonlinearSolverParameters &nonlinear,
                  const LinearSolverParameters    &linear,
                  dealii::TimerOutput             &timer);
    /// The same with the sections "Nonlinear solver" and "Linear solver"
    /// of a program's `parameters`.
    template <typename ProgramParameters>
    ContactSystem(const ComplementarityFunction &C,
                  const ProgramParameters       &parameters,
                  dealii::TimerOutput           &timer)
        : ContactSystem(C,
                        parameters.nonlinear_solver,
                        parameters.linear_solver,
                        timer)
    {
    }
    ~ContactSystem();

    /**
     * Once per mesh: forget the solvers of the old matrix, set up the
     * contact rows (the owned nodes not constrained in `u1_constraints`),
     * and size `rhs` (owned unknowns) and the coupling (owned nodes).
     * `condensed_nodes`: nodes whose balance rows are condensed away
     * (hanging nodes), left out of the residual.
     */
    void
    reinit(const dealii::IndexSet                  &owned_nodes,
           const dealii::AffineConstraints<double> &u1_constraints,
           const MPI_Comm                           comm,
           const dealii::IndexSet &condensed_nodes = dealii::IndexSet());

    /**
     * After reinit(): give `matrix` the sparsity of A, the node couplings
     * `node_pattern` (of S, or of the dG face terms; on the relevant nodes)
     * in each of A's 3 x 3 node blocks. The pattern is first completed on
     * the owned rows with the entries of other processes' cells.
     */
    void
    reinit_matrix(dealii::DynamicSparsityPattern &node_pattern,
                  const dealii::IndexSet         &relevant_nodes);

    /**
     * After the balance rows of `matrix` and F are assembled: write the
     * coupling -D_i / +D_i into the rows of u1 / u2 at every contact node
     * (D_i = coupling_of(i)) and X3_i = 0 as the row of every node of
     * `constrained_nodes`; compute the scales of the residual norms, |F| and
     * the multiplier |F|_inf / max D that balances the load, over the rows of
     * the contact nodes; throw InputError if F is not finite. With
     * `fixed_second_field` (an obstacle in place of membrane 2, whose rows
     * only fix X2) the rows of u2 get no coupling and no share of |F|.
     */
    void
    set_coupling(
      const std::function<double(dealii::types::global_dof_index)> &coupling_of,
      const std::vector<dealii::types::global_dof_index> &constrained_nodes,
      const bool fixed_second_field = false);

    /**
     * The coefficient X3_i of the multiplier that holds a unit gap open in
     * the membranes' softest mode: mu_r lambda_1(Omega) (mu_r = mu1 mu2 /
     * (mu1 + mu2), lambda_1 = 1 / C_F^2 the first eigenvalue of -Lap),
     * times (psi_i, 1) / D_i where X3_i is a force rather than a density.
     * It scales the multiplier on the continuation's path
     * (ContactRows::set_smoothing).
     */
    void
    set_gap_stiffness(const double gap_stiffness);

    /// The coupling D per node (zero away from the contact nodes).
    const Vector &
    coupling() const;

    /**
     * The weights of the constraint rows in force units: `stiffness_weight`
     * (per owned node) for rows that mainly enforce u1 = u2, the coupling
     * D_i for rows that mainly enforce X3 = 0 (ContactRows::row_weights).
     */
    void
    set_stiffness_weights(std::vector<double> stiffness_weight);

    /// Use the contact AMG preconditioner (ContactPreconditioner) with the
    /// scalar operator S of the membranes; otherwise GMRES uses ILU.
    void
    use_contact_preconditioner(const dealii::TrilinosWrappers::SparseMatrix &S,
                               const double mu1,
                               const double mu2,
                               const bool   higher_order_elements);
    bool
    has_contact_preconditioner() const;

    const ContactRows &
    contact_rows() const;

    /// R(X) = [E X - F ; C(X)] and its two dimensionless norms.
    ResidualNorms
    residual(const Vector &X, Vector &R) const;

    /// At the start of a Newton solve: the direct solver, if one is asked.
    void
    start_newton();

    /// The generalised Jacobian at X: its rows and row weights, and the
    /// preconditioner (or the factorisation) of the new matrix.
    void
    setup_jacobian(const Vector &X);

    /**
     * A dX = b with the Jacobian of the last setup_jacobian(): sparse LU, or
     * GMRES to the tolerance of the strategy (Linear solver/Tolerance, or the
     * forcing term for the inexact one). `monitor` sees the update every
     * `Linear solver/Check interval` iterations, or earlier where `schedule`
     * asks, and may stop GMRES; if it leaves an update in `accepted_update`,
     * that update is returned instead of the last one (the look-ahead of
     * AdaptiveStopping). Returns the number of GMRES iterations (0 for LU).
     */
    unsigned int
    solve(const Vector                        &b,
          Vector                              &dX,
          const Gmres<Vector>::Monitor        &monitor         = {},
          const std::function<bool(Vector &)> &accepted_update = {},
          const Gmres<Vector>::Schedule       &schedule        = {});

    /// The active set of the last Jacobian against the previous one.
    ActiveSetChange
    active_set(const Vector &X, const bool first);

    /**
     * Wire a SemismoothNewton to this system: residual, setup_jacobian,
     * solve_with_jacobian and active_set, and with `progress` a line per step.
     * A program wraps setup_jacobian or solve_with_jacobian afterwards where
     * it needs to (e.g. the start of a step's estimates).
     */
    void
    attach(SemismoothNewton<Vector>         &newton,
           const dealii::ConditionalOStream *progress);

    /// A semismooth Newton solver of this system with the nonlinear
    /// solver's parameters, started (start_newton()) and attached.
    SemismoothNewton<Vector>
    make_newton(const dealii::ConditionalOStream *progress);

    /// The matrix A = [E ; J_C] and the load F.
    dealii::TrilinosWrappers::SparseMatrix matrix;
    Vector                                 rhs;

  private:
    /// Multiply (or divide) the constraint rows of v by the row weights.
    void
    scale_constraint_rows(Vector &v, const bool divide) const;

    const ComplementarityFunction   &C;
    const NonlinearSolverParameters &nonlinear;
    const LinearSolverParameters    &linear;
    dealii::TimerOutput             &timer;
    MPI_Comm                         comm = MPI_COMM_SELF;

    dealii::IndexSet owned_nodes;
    /// Positions among the owned nodes of the rows left out of the residual.
    std::vector<std::size_t> condensed_positions;
    ContactRows              rows;
    Vector                   coupling_vector;
    double                   load_norm        = 0;
    double                   multiplier_scale = 0;
    double                   gap_stiffness    = 0;
    std::vector<double>      stiffness_weight, multiplier_weight, row_weights;
    std::vector<bool>        active_rows; ///< of the last linearisation

    std::unique_ptr<LinearSolver>                              direct_solver;
    std::unique_ptr<dealii::TrilinosWrappers::PreconditionILU> ilu;
    std::unique_ptr<ContactPreconditioner> contact_preconditioner;
  };
} // namespace VI
