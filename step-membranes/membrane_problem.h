#pragma once

#include <deal.II/base/conditional_ostream.h>
#include <deal.II/base/convergence_table.h>
#include <deal.II/base/index_set.h>
#include <deal.II/base/parameter_handler.h>
#include <deal.II/base/timer.h>
#include <deal.II/distributed/solution_transfer.h>
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
#include <vi/dual_norm.h>
#include <vi/estimators.h>
#include <vi/flux_reconstruction.h>
#include <vi/linear_solvers.h>
#include <vi/marking.h>
#include <vi/membrane_discretisation.h>
#include <vi/multiplier_function.h>
#include <vi/nodal_fields.h>
#include <vi/parameters.h>
#include <vi/process_usage.h>
#include <vi/run_record.h>
#include <vi/semismooth_newton.h>
#include <vi/stationary_problem.h>
#include <vi/summary.h>
#include <vi/test_cases.h>

#include <functional>
#include <map>
#include <memory>
#include <optional>
#include <string>

namespace StepMembranes
{
  using namespace dealii;
  // The names of the node-interleaved unknowns X = (X1, X2, X3), used by
  // all the files of the program.
  using namespace VI::NodalFields::vocabulary;

  /// The .prm interface of step-membranes: the shared sections of
  /// parameters.h and the program's own entries.
  struct Parameters
  {
    VI::ProblemParameters         problem;
    VI::MeshParameters            mesh;
    VI::DiscretizationParameters  discretization;
    VI::NonlinearSolverParameters nonlinear_solver;
    VI::LinearSolverParameters    linear_solver;
    VI::EstimatorParameters       estimators;
    VI::OutputParameters          output;
    /// Benchmark/Reference Poisson solve: time one Poisson solve per
    /// membrane on every mesh, the cost unit of bench/membranes_cost.py.
    bool reference_poisson_solve = false;
    /// Nonlinear solver/Solver: our semismooth Newton or PETSc's SNES VI.
    enum class NonlinearMethod
    {
      semismooth_newton,
      petsc_vi
    };
    NonlinearMethod nonlinear_method = NonlinearMethod::semismooth_newton;
    /// Nonlinear solver/PETSc VI type: rsls or ssls.
    std::string petsc_vi_type = "rsls";
    /// Benchmark/Compare with PETSc VI: solve every mesh a second time with
    /// SNES VI from the same initial iterate and record both in the summary.
    bool compare_with_petsc_vi = false;

    static void
    declare(ParameterHandler &prm);
    void
    parse(ParameterHandler &prm);
  };


  /**
   * Contact between two membranes with conforming finite elements Q_p,
   * p >= 1 ([DMV20], [DD21]): find u1h, u2h in X_h^p with Dirichlet data
   * g1, g2 and a multiplier lambda_h in Lambda_h^p with
   *
   *   mu1 (grad u1h, grad z1) - <lambda_h, z1>_h = (f1, z1),
   *   mu2 (grad u2h, grad z2) + <lambda_h, z2>_h = (f2, z2),
   *   <chi - lambda_h, u1h - u2h>_h >= 0   for all chi in Lambda_h^p.
   *
   * The unknowns are the nodal values X1, X2 and the multiplier coefficients
   * X3 in the basis dual to the nodal basis with respect to <.,.>_h
   * (mass-lumped for p = 1, the L2 product for p >= 2), so that the
   * coupling block D is diagonal and the constraints are nodewise:
   *
   *   [mu1 S   0   -D] X = F,   X1 - X2 >= 0,  X3 >= 0,  (X1 - X2).X3 = 0.
   *   [0   mu2 S   +D]
   *
   * Each constraint pair is rewritten with a C-function and the system is
   * solved by semismooth Newton, with linear solves that are exact, inexact
   * (fixed forcing term) or adaptive: stopped by a posteriori estimators
   * that separate the discretisation, linearisation and algebraic errors
   * ([DMV20]; doc/estimators.md). On a sequence of globally refined meshes,
   * each Newton run starts from the previous mesh's solution.
   */
  template <int dim>
  class MembraneProblem : public VI::StationaryProblem,
                          private VI::MembraneDiscretisation<dim>
  {
  public:
    MembraneProblem(const Parameters &parameters,
                    ParameterHandler &prm,
                    const MPI_Comm    comm);

  private:
    using Vector = TrilinosWrappers::MPI::Vector;
    VI_MEMBRANE_DISCRETISATION_MEMBERS(dim)

    /**
     * An iterate X = (u1h, u2h, lambda_h) as the estimators see it: its
     * fields as finite element functions, its algebraic residual r_h and
     * its equilibrated discretisation fluxes.
     */
    struct Iterate : VI::MembraneIterate
    {
      /// Whether sigma1, sigma2 were reconstructed (see add_fluxes()).
      bool has_fluxes = false;
    };

    void
    make_grid() override;
    void
    check_data() const override;
    void
    setup_system() override;
    void
    assemble_system() override;
    void
    initialize_iterate() override;
    void
    solve() override;
    /// Semismooth Newton (or the PETSc peer) from the iterate `solution`.
    void
    solve_contact_problem();
    /// One linearised system A dX = rhs, watched by the estimators.
    unsigned int
    solve_linearized(const Vector &rhs, Vector &dX);
    /// The hooks of the adaptive stopping: this program's iterates and
    /// estimates.
    typename VI::AdaptiveStopping<Iterate, VI::ContactEstimate>::Hooks
    stopping_hooks();
    /// The same discrete problem solved by PETSc's SNES VI from the iterate
    /// X, which becomes its solution (see the .cc file for the variables).
    VI::NewtonReport
    solve_with_petsc_vi(Vector &X, std::string &reason) const;
    VI::NewtonReport
    solve_obstacle_with_petsc_vi(Vector &X, std::string &reason) const;
    VI::NewtonReport
    recover_multiplier(Vector            &X,
                       const unsigned int iterations,
                       const unsigned int linear_iterations) const;
    /// Solve again with the peer from `initial` and record what it did
    /// beside this cycle's solution (Benchmark/Compare with PETSc VI).
    void
    compare_with_petsc_vi(const Vector &initial);
    /// `contact`: the nodes in contact that decide the contact cells of
    /// the cellwise multiplier (see contact_nodes()).
    /// With `fluxes` false the equilibrated fluxes are left out (the
    /// estimate of the iterate then has only its flux-free terms) and can
    /// be added later by add_fluxes().
    void
    describe_iterate(const Vector &X,
                     const Vector &contact,
                     Iterate      &iterate,
                     const bool    fluxes = true) const;
    void
    describe_fields(const Vector &X,
                    const Vector &contact,
                    Iterate      &iterate) const;
    void
    add_fluxes(Iterate &iterate) const;
    /// The eta_disc of the current mesh predicted from the last complete
    /// estimate (Estimators/Defer fluxes), if there was one.
    std::optional<double>
    predicted_eta_disc() const;
    void
    remember_eta_disc(const VI::ContactEstimate &estimate);
    /// With `equilibrated`, both dual norms (undershoots, remainder) are
    /// bounded by equilibration, whatever Estimators/Equilibrated dual norms
    /// says; `sharpen_remainder` (optional) says where the remainder's bound
    /// is worth it (ContactEstimatorInput).
    VI::ContactEstimate
    estimate(const Iterate &iterate,
             const Iterate &ahead,
             const bool     equilibrated = false,
             const std::function<bool(const VI::ContactEstimate &)>
               &sharpen_remainder = {}) const;
    VI::ContactEstimate
    estimate(const Vector &X, const bool equilibrated = false) const;
    /// Estimators/Sharpen final estimate: replaces final_estimate by the
    /// equilibrated estimate of the solution if that is smaller, with
    /// `Transmitted load = auto` the smaller of those with and without the
    /// transmitted load.
    void
    sharpen_final_estimate();
    void
    postprocess() override;
    void
    compute_errors() override;
    void
    output_results(const unsigned int cycle) const override;
    void
    refine_mesh() override;
    /// The line that says what this run solves, and how.
    std::string
    description() const override;
    /// "Newton-<C>" or the PETSc solver.
    std::string
    solver_name() const;
    /// What the cycle measured: its progress line, columns and record.
    VI::CycleNumbers
    cycle_numbers(const unsigned int cycle) const override;
    void
    record_cycle(const unsigned int cycle) override;
    /// The reference Poisson solves and the PETSc peer of the cycle
    /// (membrane_benchmarks.cc).
    void
    record_benchmarks(VI::Json &record);
    void
    write_tables() const override;
    /// The dual coefficients X3_i = <lambda_h, psi_i>_h / D_i of lambda_h.
    void
    compute_dual_coefficients(const Vector &lambda, Vector &X3) const;


    const Parameters            parameters;
    VI::MembraneData<dim>       data;
    VI::ComplementarityFunction C;

    /// Hanging node constraints of u1 and u2 in the system numbering.
    AffineConstraints<double> system_hanging_constraints;
    /// A = [E ; J_C], F, the contact rows and the linear solvers.
    VI::ContactSystem contact_system;

    Vector solution; ///< X
    /// lambda_h as a finite element function, from its nodal moments.
    const VI::MultiplierFunction multiplier_function;
    // Estimators.
    std::unique_ptr<VI::FluxReconstruction<dim>> flux_reconstruction;
    /// The equilibrated bound of the undershoots' dual norm, if asked for
    /// (Estimators/Equilibrated dual norms); after flux_reconstruction, which
    /// it refers to.
    std::unique_ptr<VI::DualNormBound<dim>> dual_norm;
    /// The nodes in contact at the linearisation point of the current
    /// Newton step: the contact cells of every iterate of the step, so that
    /// an iterate and its look-ahead share the map from moments to lambda~.
    Vector step_contact_nodes;

    /// The adaptive stopping of GMRES and Newton, and every estimate of
    /// the solve.
    VI::AdaptiveStopping<Iterate, VI::ContactEstimate> stopping;
    /// Estimators/Defer fluxes: the eta_disc predicted for the current
    /// linear solve (none: every check reconstructs its fluxes).
    std::optional<double> step_predicted_eta_disc;
    /// Whether sharpen_final_estimate() replaced final_estimate, and
    /// whether the multiplier of the final estimate carries the transmitted
    /// load.
    bool final_estimate_sharpened = false;
    bool final_estimate_transmits = false;
    /// From the eta_disc of the last complete estimate and the unknowns per
    /// field of its mesh (for predicted_eta_disc()).
    VI::EtaDiscPrediction eta_disc_prediction;

    std::unique_ptr<parallel::distributed::SolutionTransfer<dim, Vector>>
      solution_transfer;

    // What each cycle measured (beside the members of StationaryProblem).
    std::optional<VI::ContactEstimate> final_estimate;
    /// |||u - u_h|||_K per active cell (where the exact solution is known):
    /// beside the estimators in the VTU, the local effectivity.
    dealii::Vector<float> cell_error;
    /// Set-up, assembly and semismooth Newton (estimators included) of the
    /// cycle: what the contact problem costs on a given mesh.
    Timer solve_timer;
    /// The CPU time and page faults of the same span, and the reading at
    /// its start.
    VI::ProcessUsage solve_usage, usage_at_solve_start;

    /// What the peer did on this cycle's mesh (Benchmark/Compare with
    /// PETSc VI).
    struct PeerRun
    {
      bool             converged = true;
      VI::NewtonReport report;
      /// SNES's converged reason, or why it failed.
      std::string reason;
      double      seconds      = 0;
      double      error_energy = 0;
      /// max |u_peer - u_ours| / max |u_ours| over both membranes.
      double distance = 0;
    };
    std::optional<PeerRun> petsc_vi_run;
    /// The initial iterate of this cycle's solve, the peer's too.
    Vector peer_initial_iterate;
  };
} // namespace StepMembranes
