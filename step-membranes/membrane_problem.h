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
#include <deal.II/lac/affine_constraints.h>
#include <deal.II/lac/trilinos_sparse_matrix.h>
#include <deal.II/lac/trilinos_vector.h>
#include <memory>
#include <vi/complementarity.h>
#include <vi/contact_rows.h>
#include <vi/geometry.h>
#include <vi/linear_solvers.h>
#include <vi/parameters.h>
#include <vi/semismooth_newton.h>
#include <vi/summary.h>
#include <vi/test_cases.h>

namespace StepMembranes
{
  using namespace dealii;

  /// The .prm interface of step-membranes (sections of DESIGN.md).
  struct Parameters
  {
    VI::ProblemParameters         problem;
    VI::MeshParameters            mesh;
    VI::DiscretizationParameters  discretization;
    VI::NonlinearSolverParameters nonlinear_solver;
    VI::LinearSolverParameters    linear_solver;
    VI::OutputParameters          output;

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
   * Each constraint pair is rewritten with a C-function and the whole system
   * is solved by semismooth Newton on a sequence of globally refined meshes,
   * each Newton run starting from the previous mesh's solution.
   */
  template <int dim>
  class MembraneProblem
  {
  public:
    MembraneProblem(const Parameters &parameters,
                    ParameterHandler &prm,
                    const MPI_Comm    comm);

    void
    run();

  private:
    void
    check_data() const;
    void
    make_grid();
    void
    setup_system();
    void
    assemble_system();
    void
    initialize_iterate();
    void
    solve();
    void
    postprocess();
    void
    compute_errors();
    void
    output_results(const unsigned int cycle) const;
    void
    refine_mesh();
    void
    record_cycle(const unsigned int cycle);
    void
    write_tables() const;

    /// lambda_h (nodal coefficients) from the dual coefficients X3.
    void
    compute_multiplier(const TrilinosWrappers::MPI::Vector &X3,
                       TrilinosWrappers::MPI::Vector       &lambda) const;
    /// The dual coefficients X3_i = <lambda_h, psi_i>_h / D_i of lambda_h.
    void
    compute_dual_coefficients(const TrilinosWrappers::MPI::Vector &lambda,
                              TrilinosWrappers::MPI::Vector       &X3) const;

    VI::ResidualNorms
    residual(const TrilinosWrappers::MPI::Vector &X,
             TrilinosWrappers::MPI::Vector       &R) const;

    const Parameters            parameters;
    ParameterHandler           &prm;
    const MPI_Comm              comm;
    ConditionalOStream          pcout;
    mutable TimerOutput         timer;
    const VI::Geometry          geometry;
    VI::MembraneData<dim>       data;
    VI::ComplementarityFunction C;

    parallel::distributed::Triangulation<dim> triangulation;
    std::unique_ptr<Mapping<dim>>             mapping;
    FE_Q<dim>                                 fe;
    DoFHandler<dim>                           dof_handler;

    // Nodes (scalar DoFs) and the node-interleaved unknowns X.
    IndexSet owned_nodes, relevant_nodes;
    IndexSet owned_system, relevant_system;

    AffineConstraints<double> hanging_node_constraints;
    AffineConstraints<double> u1_constraints, u2_constraints;
    AffineConstraints<double> system_constraints;
    VI::ContactRows           contact_rows;

    TrilinosWrappers::SparseMatrix system_matrix; ///< A = [E ; J_C]
    TrilinosWrappers::MPI::Vector  system_rhs;    ///< F
    TrilinosWrappers::MPI::Vector  solution;      ///< X
    TrilinosWrappers::MPI::Vector  coupling;      ///< D_ii per node
    TrilinosWrappers::SparseMatrix mass_matrix;   ///< L2 Gram matrix, p >= 2
    double                         load_norm        = 0;
    double                         multiplier_scale = 0;

    // The discrete solution as finite element functions (with ghosts).
    TrilinosWrappers::MPI::Vector u1_h, u2_h, gap_h, lambda_h, contact_set;

    std::unique_ptr<parallel::distributed::
                      SolutionTransfer<dim, TrilinosWrappers::MPI::Vector>>
      solution_transfer;

    // What each cycle measured.
    VI::NewtonReport        newton_report;
    types::global_dof_index n_contact_nodes  = 0;
    double                  error_energy     = 0;
    double                  error_multiplier = 0;
    Timer                   cycle_timer;

    ConvergenceTable table;
    VI::Json         summary;
  };
} // namespace StepMembranes
