#pragma once

#include <deal.II/base/index_set.h>
#include <deal.II/lac/affine_constraints.h>
#include <deal.II/lac/trilinos_sparse_matrix.h>
#include <deal.II/lac/trilinos_vector.h>

#include <vi/complementarity.h>
#include <vi/semismooth_newton.h>

#include <array>
#include <vector>

namespace VI
{
  /**
   * The complementarity rows of the two-membrane problems: at every node i
   * that carries a constraint (locally owned, not on the Dirichlet boundary,
   * not hanging) the pair
   *
   *   a_i = X1_i - X2_i >= 0,   b_i = X3_i >= 0,   a_i b_i = 0
   *
   * is written as the row C(a_i, b_i) = 0 of the semismooth Newton system, in
   * the X3 row of node i of the node-interleaved vector X (see NodalFields).
   */
  class ContactRows
  {
  public:
    /// The owned nodes not constrained in `u1_constraints`.
    void
    reinit(const dealii::IndexSet                  &owned_nodes,
           const dealii::AffineConstraints<double> &u1_constraints);

    /// Global indices of the constrained nodes owned here.
    const std::vector<dealii::types::global_dof_index> &
    nodes() const;

    /// Their positions among the locally owned nodes.
    const std::vector<std::size_t> &
    local_positions() const;

    /**
     * Overwrite the X3 rows of R with C(a_i, b_i) and return the
     * dimensionless complementarity residual over all processes,
     *
     *   max_i |C(a_i / U, b_i / B)|,   U = max_i max(|X1_i|, |X2_i|),
     *   B = max(max_i |X3_i|, multiplier_scale),
     *
     * which vanishes exactly when the pairs are complementary (both
     * C-functions keep their zero set under positive scaling of each
     * argument) and is insensitive to the units of u and lambda.
     * `multiplier_scale` is the size a multiplier coefficient would have to
     * balance the load (|F| / max D), so that round-off in X3 is not mistaken
     * for a violation when there is no contact at all.
     */
    /// With smoothing (set_smoothing()) the rows are those of C_mu, and
    /// `norms.smoothed_complementarity` is their dimensionless maximum;
    /// `norms.complementarity` is always that of C.
    void
    evaluate(const ComplementarityFunction               &C,
             const dealii::TrilinosWrappers::MPI::Vector &X,
             const double                                 multiplier_scale,
             dealii::TrilinosWrappers::MPI::Vector       &R,
             ResidualNorms                               &norms) const;

    /**
     * Smooth the constraint rows with the parameter mu > 0, or return to C
     * with mu = 0 (SemismoothNewton::set_smoothing). The smoothed row of
     * node i is U C_mu(a_i / U, b_i / B) with
     *
     *   U = max_i max(|X1_i|, |X2_i|),
     *   B = max(max_i |X3_i|, path_stiffness_factor gap_stiffness U),
     *
     * taken at X when smoothing starts and kept while it lasts, so that mu
     * is dimensionless and the homotopy does not move with the iterate.
     * `gap_stiffness` is the coefficient X3_i per unit of gap in the
     * softest mode of the membranes, mu_r lambda_1(Omega) (ContactSystem::
     * set_gap_stiffness): B is then the same on every mesh and in every
     * unit of length, tension and load. evaluate()'s scale |F| / max D,
     * which holds the Dirichlet data (of order |g| / h^2 once divided by
     * D), made the scaled multipliers, and with them the path
     * x_i y_i = mu^2, shrink like h^2 (doc/reference.md, "Continuation").
     */
    void
    set_smoothing(const double                                 mu,
                  const dealii::TrilinosWrappers::MPI::Vector &X,
                  const double                                 gap_stiffness);

    /// The gap stiffness of set_smoothing(): mu_gap lambda_1 = mu_gap /
    /// C_F^2, times `force_per_density` = (psi_i, 1) / D_i where X3_i is a
    /// force rather than a density.
    static double
    gap_stiffness(const double mu_gap,
                  const double friedrichs_constant,
                  const double force_per_density = 1.)
    {
      return mu_gap / (friedrichs_constant * friedrichs_constant) *
             force_per_density;
    }

    /// B over the multiplier of a gap U in the softest mode (measured:
    /// doc/reference.md, "Continuation").
    static constexpr double path_stiffness_factor = 200.;

    /**
     * The rows of the interior-point continuation
     * (SemismoothNewton::InteriorPointRows), with the scales U, B of
     * set_smoothing() frozen at X: the row of node i is
     *
     *   U (x_i y_i - t_i) / (x_i + y_i),   x_i = a_i / U,  y_i = b_i / B,
     *
     * whose Newton step is that of x_i y_i = t_i (the division, evaluated
     * where the Jacobian is, only gives the row the size of a gap row:
     * (y, x) / (x + y) with entries between 0 and 1, as min's and
     * Fischer-Burmeister's). enter_interior_point() puts every pair on
     * x y = mu2 (see SemismoothNewton::InteriorPointRows::enter) by moving
     * X1 and X2 apart or together by the same amount and setting X3.
     */
    void
    enter_interior_point(dealii::TrilinosWrappers::MPI::Vector &X,
                         const double                           mu2,
                         const double                           gap_stiffness);

    /// t_i = target - dx_i dy_i, or target if dX is null.
    void
    set_interior_point_targets(const dealii::TrilinosWrappers::MPI::Vector *dX,
                               const double target);

    /// Gondzio's centrality correction: add to t_i what moves the product
    /// (x_i + s dx_i)(y_i + s dy_i) into [target / 10, 10 target] (a pair
    /// above it at most by 10 target).
    void
    centre_interior_point_targets(
      const dealii::TrilinosWrappers::MPI::Vector &X,
      const dealii::TrilinosWrappers::MPI::Vector &dX,
      const double                                 s,
      const double                                 target);

    /// Set the increment of each pair's smaller member from its row,
    /// dy = (t - x y - y dx) / x where x >= y, dx = (t - x y - x dy) / y
    /// (through X1 and X2, as enter_interior_point()) elsewhere: an error
    /// r of the row becomes one of at most 2 r / U in the smaller member.
    void
    solve_interior_point_rows(const dealii::TrilinosWrappers::MPI::Vector &X,
                              dealii::TrilinosWrappers::MPI::Vector &dX) const;

    /// {the largest t with x + t dx, y + t dy >= 0 at every row, the mean
    /// of (x + s dx)(y + s dy)} over all processes.
    std::array<double, 2>
    step_to_boundary(const dealii::TrilinosWrappers::MPI::Vector &X,
                     const dealii::TrilinosWrappers::MPI::Vector &dX,
                     const double                                 s) const;

    /// Back to the rows of C.
    void
    leave_interior_point();

    /// Whether the rows follow the central path (smoothed or interior-point
    /// rows), which the estimators of C do not see.
    bool
    on_path() const
    {
      return mu > 0 || interior_point;
    }

    /**
     * X is the point of the next linearisation: called by the problem before
     * it assembles a Jacobian from the rows (row_gradient() and all that
     * use it). The one thing it decides is the cold start: if every row of
     * X sits at the origin, a_i = b_i = 0 on all processes (the zero
     * initial guess, which says nothing about contact), the rows there take
     * the free side of the kink (ComplementarityFunction::
     * free_side_gradient_at_origin), so that Newton's first step solves the
     * membranes without contact and the second starts from where that
     * solution penetrates, the classical start of the primal-dual active
     * set method. Taking the contact side instead, as the kink does
     * elsewhere, glues the membranes in the whole domain, and the active set
     * then frees one ring of nodes per step (doc/stress.md, "Cold starts").
     * A data guess, whose contact set sits at the origin and whose gaps
     * elsewhere do not, keeps the contact side there.
     */
    void
    set_linearisation_point(const dealii::TrilinosWrappers::MPI::Vector &X);

    /// The row function at one node, C(a, b) or U C_mu(a / U, b / B).
    double
    row_value(const ComplementarityFunction &C,
              const double                   a,
              const double                   b) const;

    /// Its gradient (d/da, d/db): an element of the generalised Jacobian
    /// (at the origin, the one set_linearisation_point() chose).
    std::array<double, 2>
    row_gradient(const ComplementarityFunction &C,
                 const double                   a,
                 const double                   b) const;

    /**
     * Write the rows w_i (dC/da, -dC/da, dC/db) of an element of the
     * generalised Jacobian into the X3 rows of A (entries that exist in the
     * sparsity pattern; followed by A.compress(insert) by the caller), with
     * row weights w_i (1 if `weights` is empty; one per contact node, in the
     * order of nodes()).
     */
    void
    set_jacobian_rows(const ComplementarityFunction               &C,
                      const dealii::TrilinosWrappers::MPI::Vector &X,
                      dealii::TrilinosWrappers::SparseMatrix      &A,
                      const std::vector<double> &weights = {}) const;

    /**
     * Weights that give the linearised constraint rows the units of the
     * balance equations (forces), so that relative residuals of the linear
     * solver weigh both kinds of rows alike: `stiffness_weight`_k for rows
     * that mainly enforce u1 = u2 (|dC/da| >= |dC/db|), `multiplier_weight`_k
     * for rows that mainly enforce X3 = 0. Vectors over the owned nodes.
     */
    std::vector<double>
    row_weights(const ComplementarityFunction               &C,
                const dealii::TrilinosWrappers::MPI::Vector &X,
                const std::vector<double>                   &stiffness_weight,
                const std::vector<double> &multiplier_weight) const;

    /**
     * The active set of the linearisation at X: the rows whose element of
     * the generalised Jacobian mainly enforces u1 = u2, |dC/da| >= |dC/db|
     * (as in row_weights(); for the min-function the nodes with a_i <= b_i),
     * one flag per node of nodes(). Semismooth Newton-min is the primal-dual
     * active set method, and these sets are its iterates. `active` holds the
     * previous linearisation's flags if `compare`, and is overwritten.
     * Returns the global numbers of active and, if `compare`, switched rows
     * (the SemismoothNewton::active_set callback of the contact problems).
     */
    ActiveSetChange
    linearised_active_set(const ComplementarityFunction               &C,
                          const dealii::TrilinosWrappers::MPI::Vector &X,
                          std::vector<bool>                           &active,
                          const bool compare) const;

    /**
     * indicator_i = 1 at the nodes in contact (a_i <= b_i: the min-function
     * enforces u1 = u2 there), 0 elsewhere; a scalar vector over the nodes,
     * without ghosts. Returns the global number of nodes in contact.
     */
    dealii::types::global_dof_index
    contact_set(const dealii::TrilinosWrappers::MPI::Vector &X,
                dealii::TrilinosWrappers::MPI::Vector       &indicator) const;

    /**
     * Give `newton` the rows' continuation, both methods: set_smoothing()
     * and the interior-point rows, with the gap stiffness of
     * set_smoothing(). The rows must outlive the solve.
     */
    void
    attach_continuation(
      SemismoothNewton<dealii::TrilinosWrappers::MPI::Vector> &newton,
      const double                                             gap_stiffness);

  private:
    /// U = max_i max(|X1_i|, |X2_i|) and B = max(max_i |X3_i|,
    /// multiplier_scale) over all processes (see evaluate()).
    std::array<double, 2>
    scales(const dealii::TrilinosWrappers::MPI::Vector &X,
           const double                                 multiplier_scale) const;

    /// Whether a row with gradient g (row_gradient()) mainly enforces
    /// u1 = u2: |dC/dx| >= |dC/dy| in the dimensionless arguments.
    bool
    enforces_gap(const std::array<double, 2> &g) const;

    /// The smoothing parameter (0: none) and the frozen scales U, B
    /// (1 without smoothing, so that the rows are C(a, b) bit for bit).
    double mu = 0., U = 1., B = 1.;

    /// Whether the rows are those of the interior-point method, and their
    /// targets t_i (one per node of nodes()).
    bool                interior_point = false;
    std::vector<double> targets;

    /// U, B of the path at X (set_smoothing()).
    void
    freeze_scales(const dealii::TrilinosWrappers::MPI::Vector &X,
                  const double                                 gap_stiffness);

    /// Whether the linearisation point has every row at the origin
    /// (set_linearisation_point()).
    bool cold_start = false;

    std::vector<dealii::types::global_dof_index> node_indices;
    /// Position of each node among the locally owned nodes.
    std::vector<std::size_t> positions;
  };
} // namespace VI
