#pragma once

#include <deal.II/base/conditional_ostream.h>
#include <deal.II/base/convergence_table.h>
#include <deal.II/base/index_set.h>
#include <deal.II/base/parameter_handler.h>
#include <deal.II/base/timer.h>
#include <deal.II/distributed/tria.h>
#include <deal.II/dofs/dof_handler.h>
#include <deal.II/fe/fe_q.h>
#include <deal.II/fe/mapping.h>
#include <deal.II/fe/mapping_q_cache.h>
#include <deal.II/lac/affine_constraints.h>
#include <deal.II/lac/trilinos_precondition.h>
#include <deal.II/lac/trilinos_sparse_matrix.h>
#include <deal.II/lac/trilinos_vector.h>

#include <vi/adaptive_stopping.h>
#include <vi/complementarity.h>
#include <vi/contact_system.h>
#include <vi/domain.h>
#include <vi/estimators.h>
#include <vi/flux_reconstruction.h>
#include <vi/linear_solvers.h>
#include <vi/membrane_discretisation.h>
#include <vi/multiplier_function.h>
#include <vi/nodal_fields.h>
#include <vi/run_record.h>
#include <vi/semismooth_newton.h>
#include <vi/summary.h>

#include "parabolic_data.h"
#include "parabolic_parameters.h"

#include <array>
#include <memory>
#include <optional>
#include <string>
#include <vector>

namespace StepParabolic
{
  using namespace dealii;
  // The names of the node-interleaved unknowns X = (X1, X2, X3), used by
  // all the files of the program.
  using namespace VI::NodalFields::vocabulary;

  /**
   * The a posteriori estimate of one time step I_n = (t_(n-1), t_n) for an
   * iterate u_h^n (doc/step-parabolic.md has the theorem): with u_ht the
   * function linear in time between u_h^(n-1) and u_h^n, lambda_h^n and the
   * fluxes sigma^n constant on I_n,
   *
   *   eta_n = ( int_In A(t)^2 + eta_C(t) dt )^(1/2) + |eta_osc|_In,
   *   A(t)  = eta_1(t) + eta_nonc1(t) + eta_nonc2 + eta_dt,
   *
   * where eta_1(t), eta_nonc1(t), eta_C(t) are the estimators of the steady
   * problem (VI::estimate_contact_error) evaluated for u_ht(t), eta_dt the
   * time derivative of the cone correction in H^-1 and eta_osc the change
   * of the forces within I_n. The time integral is the trapezoidal rule
   * of `time_points()` (an upper bound: the integrand is convex in t). All
   * members are for the whole domain.
   */
  struct StepEstimate
  {
    double eta = 0; ///< eta_n
    /// eta_n <= eta_disc + eta_lin + eta_alg, each an L2(I_n) norm.
    double eta_disc = 0, eta_lin = 0, eta_alg = 0;
    /// eta_lin without what the previous step left (its cone correction
    /// enters eta_dt): the part the current Newton iteration controls.
    double eta_lin_controlled = 0;
    /// (dt/3)^(1/2) |||u_h^n - u_h^(n-1)|||: the temporal estimator, the
    /// part of the flux estimator due to u_ht(t) != u_h^n.
    double eta_time = 0;
    /// dt^(1/2) times the discretisation estimator at t_n: the spatial one.
    double eta_space   = 0;
    double oscillation = 0; ///< |eta_osc|_L2(In)
    double eta_dt      = 0; ///< eta_dt
    /// int_In |||s~_ht - u_ht|||^2 dt (total and its disc / lin parts)
    /// and |s~_h^n - u_h^n| (L2): the cone correction at the end.
    double nonc_squared = 0, nonc_squared_disc = 0, nonc_squared_lin = 0;
    double final_nonc = 0, final_nonc_disc = 0, final_nonc_lin = 0;
    /// The second bound, with (d_t d, e~) taken in L2 instead of H^-1:
    /// eta_n without eta_dt (and its disc / lin parts), and |d^n - d^(n-1)|
    /// (L2, with its parts), which it sums over the steps.
    double eta_l2 = 0, eta_l2_disc = 0, eta_l2_lin = 0;
    double change = 0, change_disc = 0, change_lin = 0;
    /// The variants v = 2 (alpha - 1) + k of the second bound that also take
    /// the load of membrane alpha in L2, with its flux zero, and for k = 1
    /// the part of lambda~ that eta_nonc2 bounds: eta_l2 with
    /// |mu_alpha^(1/2) grad u_alpha,ht| as membrane alpha's flux term (no
    /// residual, no remainder; for k = 1 no eta_nonc2), and dt_n |f_alpha(t_n)
    /// - d_t u_alpha,h^n - (-1)^alpha lambda~^n| (plus dt_n 2^(1/2) |lambda~ -
    /// c_K lambda~^pos| for k = 1), which they sum over the steps with the
    /// change of d. Zero over an obstacle, where there are none.
    std::array<double, 4> eta_variant{}, l2_variant{};
    /// The steady estimate at t_n (cellwise indicators for the output).
    VI::ContactEstimate at_end;
  };


  /**
   * The time-dependent contact between two membranes ([DMV20p]) with
   * conforming finite elements Q_p and backward Euler: at every time step
   * find u_h^n in X_h^p (Dirichlet data g(t_n)) and lambda_h^n with
   *
   *   (u_h^n - u_h^(n-1), z) / dt_n + sum_alpha mu_alpha (grad u_alpha,h^n,
   *     grad z_alpha) - <lambda_h^n, z1 - z2>_h = (f(t_n), z),
   *   <chi - lambda_h^n, u1h^n - u2h^n>_h >= 0,
   *
   * i.e. the saddle point system of step-membranes with the blocks
   * E^n = mu_alpha S + M / dt_n, solved by semismooth Newton (min or
   * Fischer-Burmeister) with exact, inexact or adaptive linear solves. The
   * estimators of the steady problem, evaluated along the time step, give a
   * guaranteed bound of the error in L2(0, T; H^1) and at the final time,
   * split into discretisation, linearisation and algebraic parts, which
   * stop the solvers (adaptive strategy) and can choose dt_n.
   */
  template <int dim>
  class ParabolicProblem : private VI::MembraneDiscretisation<dim>
  {
  public:
    ParabolicProblem(const Parameters &parameters,
                     ParameterHandler &prm,
                     const MPI_Comm    comm);

    void
    run();

  private:
    VI_MEMBRANE_DISCRETISATION_MEMBERS(dim)
    using typename Discretisation::Vector;

    /**
     * An iterate X^n = (u1h^n, u2h^n, lambda_h^n) as the estimators see it
     * (VI::MembraneIterate), with the discrete time derivative
     * d_t u_h = (u_h^n - u_h^(n-1)) / dt_n.
     */
    struct Iterate : VI::MembraneIterate
    {
      Vector dt_u1, dt_u2;
      /// u1h, u2h, s1, s2 without ghosts (for interpolation in time).
      Vector owned[4];
      /// With the cellwise multiplier: 2 <lambda_h^n, u1h^(n-1) -
      /// u2h^(n-1)>_h, the contact term's linearisation part at t_(n-1).
      double previous_complementarity = 0;
    };

    /// The terms of the step estimate beyond the steady estimators.
    struct ParabolicTerms
    {
      double eta_dt = 0, eta_dt_disc = 0, eta_dt_lin = 0;
      double eta_dt_lin_controlled = 0;
      double change = 0, change_disc = 0, change_lin = 0; ///< |d^n - d^(n-1)|
      double final_nonc = 0, final_nonc_disc = 0, final_nonc_lin = 0;
      double time_energy = 0; ///< |||u_h^n - u_h^(n-1)|||
    };

    /// Running sums over the accepted steps (saved in checkpoints).
    struct Accumulated
    {
      double eta_init    = 0;
      double eta_squared = 0, disc_squared = 0, lin_squared = 0,
             alg_squared  = 0;
      double nonc_squared = 0, nonc_squared_disc = 0, nonc_squared_lin = 0;
      double final_nonc = 0, final_nonc_disc = 0, final_nonc_lin = 0;
      /// The second bound's sums: of eta_l2^2 (and parts), of |d^n - d^(n-1)|.
      double l2_squared = 0, l2_disc_squared = 0, l2_lin_squared = 0;
      double change = 0, change_disc = 0, change_lin = 0;
      /// The sums of its variants (StepEstimate::eta_variant): of
      /// eta_variant^2 and of l2_variant.
      std::array<double, 4> variant_squared{}, variant_l2{};
      double             error_squared = 0; ///< sum_n int_In |||u - u_ht|||^2
      double             final_error   = 0; ///< |u(t_n) - u_h^n|
      unsigned long long newton = 0, linear = 0;
      unsigned int       rejected = 0;

      /// The guaranteed bound of the error up to the current time, the
      /// smallest of the first two and the second's variants
      /// (doc/step-parabolic.md), and its components
      /// (eta <= eta_init + eta_disc + eta_lin + eta_alg).
      double
      eta() const;
      /// Whether the second bound, with d_t d in L2, is below the first
      /// (its variants aside: the split of eta comes from these two).
      bool
      l2_bound_is_smaller() const;
      /// Which bound eta() is: 0 if the first or the second, v + 1 if the
      /// second's variant v (StepEstimate::eta_variant).
      unsigned int
      smallest_variant() const;
      /// The two bounds without the non-conformity N: (eta_init^2 + sum_n
      /// eta_n^2)^(1/2) and G + (eta_init^2 + sum_n eta_l2,n^2)^(1/2).
      double
      h_minus_1_bound() const;
      double
      l2_bound() const;
      /// G_v + (eta_init^2 + sum_n eta_variant,n^2)^(1/2) with G_v = G +
      /// sum_n l2_variant,n: the second bound's variant v.
      double
      variant_bound(const unsigned int v) const;
      double
      eta_disc() const;
      double
      eta_lin() const;
      double
      eta_alg() const;
      /// (int_0^t |||u - u_ht|||^2 + |(u - u_h)(t)|^2)^(1/2).
      double
      error() const;
    };

    /// One row of the table (saved in checkpoints).
    struct StepRecord
    {
      unsigned int       step = 0;
      double             time = 0, dt = 0;
      unsigned int       newton = 0, linear = 0, rejected = 0;
      unsigned long long contact  = 0;
      double             eta_step = 0, eta_time = 0, eta = 0;
      double             error = 0, effectivity = 0;
    };

    // Set-up.
    void
    check_data() const;
    void
    setup_system();
    void
    assemble_system();
    void
    set_initial_values();
    void
    store_previous_step();

    // The run's phases.
    /// The line that says what this run solves, and how.
    std::string
    description() const;
    void
    start_run();
    void
    solve_until_accepted();
    void
    accept_time_step();
    void
    print_step(const double wall_seconds) const;
    void
    finish_run(const bool stopped);

    // One time step.
    void
    solve_time_step();
    /// The hooks of the adaptive stopping: this program's iterates and
    /// estimates.
    typename VI::AdaptiveStopping<Iterate, StepEstimate>::Hooks
    stopping_hooks();

    // Estimators.
    /// `contact`: the nodes in contact that decide the contact cells of
    /// the cellwise multiplier (and J).
    void
    describe_iterate(const Vector &X,
                     const Vector &contact,
                     Iterate      &iterate) const;
    StepEstimate
    estimate(const Iterate &iterate, const Iterate &ahead) const;
    StepEstimate
    estimate(const Vector &X) const;
    ParabolicTerms
    parabolic_terms(const Iterate &iterate) const;
    double
    force_oscillation() const;
    double
    initial_error_estimate() const;
    /// (theta, weight) pairs of the time quadrature on I_n (theta = 0 at
    /// t_(n-1), 1 at t_n).
    std::vector<std::pair<double, double>>
    time_points() const;

    // After a step.
    void
    postprocess();
    void
    compute_errors();
    void
    choose_next_time_step(const StepEstimate &estimate, bool &accept);
    void
    record_step(const double wall_seconds);
    void
    output_results();
    void
    write_tables() const;
    /// The totals of the run so far, for summary.json.
    void
    add_totals(VI::Json &summary) const;

    // Checkpoints (parabolic_checkpoint.cc).
    void
    write_checkpoint();
    void
    read_checkpoint();
    std::vector<std::string>
    problem_fingerprint() const;
    void
    compare_with_run(const std::string &directory);
    /// (1 - theta) a + theta b into a ghosted vector.
    void
    interpolate_in_time(const Vector &a,
                        const Vector &b,
                        const double  theta,
                        Vector       &result) const;

    const Parameters            parameters;
    ParameterHandler           &prm;
    ConditionalOStream          pcout;
    mutable TimerOutput         timer;
    const Point<dim>            center;
    ParabolicData<dim>          data;
    VI::ComplementarityFunction C;
    const double                friedrichs_constant;

    /// A = [E^n ; J_C], F^n, the contact rows and the linear solvers.
    VI::ContactSystem contact_system;

    Vector solution; ///< X^n
    /// lambda_h as a finite element function, from its nodal moments.
    const VI::MultiplierFunction multiplier_function;
    /// The dt of stiffness_matrix = S + M / (mu dt) (mu1 = mu2 = mu) and of
    /// the AMG preconditioner built from it.
    double preconditioner_dt = 0;
    /// Ring test: the ring of every owned node.
    std::vector<unsigned int> node_ring;

    std::unique_ptr<VI::FluxReconstruction<dim>> flux_reconstruction;
    /// The nodes in contact at the linearisation point of the current
    /// Newton step (see step-membranes).
    Vector step_contact_nodes;

    // The time step: t_(n-1) = time, t_n = time + time_step.
    double       time               = 0;
    double       time_step          = 0; ///< dt_n of the step being solved
    double       next_time_step     = 0;
    unsigned int step               = 0; ///< completed steps
    unsigned int steps_this_run     = 0;
    unsigned int rejected_this_step = 0;
    double       step_oscillation   = 0; ///< |eta_osc|_In of the step
    /// Work of the current step, including rejected attempts.
    unsigned int newton_this_step = 0, linear_this_step = 0;

    // The previous step: X^(n-1), and u_h^(n-1), s_h^(n-1) (with ghosts).
    Vector previous_solution;
    Vector previous_u1, previous_u2, previous_s1, previous_s2;
    /// The same without ghosts.
    Vector         previous_owned[4];
    mutable Vector interpolation_buffer;

    /// The adaptive stopping of GMRES and Newton, and every estimate of
    /// the step.
    VI::AdaptiveStopping<Iterate, StepEstimate> stopping;

    VI::NewtonReport                newton_report;
    std::optional<StepEstimate>     final_estimate;
    types::global_dof_index         n_contact_nodes = 0;
    std::vector<unsigned long long> contact_per_ring;
    double step_error_energy = 0; ///< |||u(t_n) - u_h^n|||

    Accumulated                                 totals;
    std::vector<StepRecord>                     records;
    std::vector<std::string>                    step_json; ///< summary "steps"
    std::vector<std::pair<double, std::string>> vtu_files;
    std::string                                 checkpoint_mesh;

    /// Header, summary.json, failure guard, timing and closing line.
    VI::RunRecord run_record;
  };
} // namespace StepParabolic
