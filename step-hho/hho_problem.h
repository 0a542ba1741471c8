#pragma once

#include <deal.II/base/array_view.h>
#include <deal.II/base/index_set.h>
#include <deal.II/base/parameter_handler.h>
#include <deal.II/distributed/solution_transfer.h>
#include <deal.II/distributed/tria.h>
#include <deal.II/dofs/dof_handler.h>
#include <deal.II/fe/fe_dgp.h>
#include <deal.II/fe/fe_face.h>
#include <deal.II/fe/fe_values.h>
#include <deal.II/fe/mapping.h>
#include <deal.II/lac/affine_constraints.h>
#include <deal.II/lac/full_matrix.h>
#include <deal.II/lac/trilinos_sparse_matrix.h>
#include <deal.II/lac/trilinos_vector.h>

#include <vi/adaptive_stopping.h>
#include <vi/complementarity.h>
#include <vi/contact_rows.h>
#include <vi/dg_estimators.h>
#include <vi/domain.h>
#include <vi/ghosted_copy.h>
#include <vi/nodal_fields.h>
#include <vi/parameters.h>
#include <vi/semismooth_newton.h>
#include <vi/stationary_problem.h>
#include <vi/summary.h>
#include <vi/test_cases.h>

#include "static_condensation.h"

#include <array>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

namespace StepHHO
{
  using namespace dealii;
  // The names of the node-interleaved cell unknowns (X1, X2, X3), used by
  // all the files of the program.
  using namespace VI::NodalFields::vocabulary;

  class JacobianSolver;

  /**
   * The .prm interface of step-hho: the sections of step-membranes,
   * with Method = hho, the switch "Discretization/Static
   * condensation", and conjugate gradients for the condensed system in
   * "Linear solver".
   */
  struct Parameters
  {
    VI::ProblemParameters         problem;
    VI::MeshParameters            mesh;
    VI::DiscretizationParameters  discretization;
    bool                          static_condensation = true;
    std::string                   contact_nodes       = "gauss-padua";
    std::string                   gradient_degree     = "p";
    bool                          estimators          = false;
    VI::NonlinearSolverParameters nonlinear_solver;
    VI::LinearSolverParameters    linear_solver;
    VI::OutputParameters          output;

    static void
    declare(ParameterHandler &prm);
    void
    parse(ParameterHandler &prm);
  };


  /**
   * Contact between two membranes with the Hybrid High-Order method of the
   * seed (slides "The Hybrid High-Order method", [DD21]). Unknowns of each
   * membrane alpha: a polynomial u_alpha,K in P_p(K) on every cell and
   * u_alpha,F in P_{p-1}(F) on every face (the L2 projection of g_alpha on
   * boundary faces); the multiplier lambda_h in P_p(K) on every cell. With
   * the local bilinear form a_K = (G_K ., G_K .)_K + s_K
   * (local_operators.h), find them with
   *
   *   mu1 sum_K a_K(u1, v1) - sum_K (lambda_h, v1,K)_K = sum_K (f1, v1,K)_K,
   *   mu2 sum_K a_K(u2, v2) + sum_K (lambda_h, v2,K)_K = sum_K (f2, v2,K)_K,
   *
   * and the complementarity at the nodes x_I of every cell (Padua points):
   *
   *   (u1,K - u2,K)(x_I) >= 0,  X3_I >= 0,  (u1,K - u2,K)(x_I) X3_I = 0.
   *
   * The cell unknowns are the nodal values X1, X2 at x_I (nodal basis phi_I
   * of P_p(K)) and the coefficients X3 of lambda_h in the basis dual to
   * phi_I in L2(K), X3_I = (lambda_h, phi_I)_K, so that the coupling block
   * is the identity I_d of the slides and the constraints are nodewise.
   *
   * Each semismooth Newton step solves the linearised system either whole
   * (sparse LU), or by static condensation: the cell unknowns of both
   * membranes and the multiplier are eliminated cell by cell, the system on
   * the faces is solved (CG + AMG, or LU), and the cell unknowns are
   * recovered (static_condensation.h). Written for the weighted mean and
   * the difference of the membranes, the face system is block diagonal:
   * the mean's block does not change from one Newton step to the next. Both
   * ways give the same Newton iterates.
   */
  template <int dim>
  class HHOProblem : public VI::StationaryProblem
  {
  public:
    HHOProblem(const Parameters &parameters,
               ParameterHandler &prm,
               const MPI_Comm    comm);
    ~HHOProblem();

  private:
    void
    check_data() const override;
    void
    make_grid() override;
    void
    setup_system() override;
    // The phases of setup_system().
    void
    distribute_unknowns();
    void
    index_local_unknowns();
    void
    make_face_constraints();
    void
    project_boundary_data();
    void
    constrain_hanging_faces();
    void
    make_face_sparsity();
    void
    make_jacobian_sparsity();
    void
    reinit_vectors();
    void
    assemble_system() override;
    void
    initialize_iterate() override;
    void
    solve() override;
    void
    postprocess() override;
    /// u1_h, u2_h, gap_h and lambda_h (FE_DGP, ghosted) of `solution`.
    void
    cell_fields();
    void
    compute_errors() override;
    /// The a posteriori estimate of the iterate in u1_h, u2_h, lambda_h
    /// (hho_estimate.cc) and its parts.
    VI::DGContactEstimate
    estimate() const;
    void
    broken_fields(const DoFHandler<dim> &broken,
                  const Quadrature<dim> &quadrature,
                  TrilinosWrappers::MPI::Vector (&u)[2],
                  TrilinosWrappers::MPI::Vector &lambda,
                  TrilinosWrappers::MPI::Vector &positive) const;
    void
    equilibrated_fluxes(const DoFHandler<dim>     &flux,
                        const DoFHandler<dim>     &broken,
                        const Quadrature<dim>     &quadrature,
                        const Quadrature<dim - 1> &face_quadrature,
                        TrilinosWrappers::MPI::Vector (&sigma)[2],
                        TrilinosWrappers::MPI::Vector (&r)[2]) const;
    void
    output_results(const unsigned int cycle) const override;
    void
    refine_mesh() override;
    std::string
    description() const override;
    VI::CycleNumbers
    cycle_numbers(const unsigned int cycle) const override;
    void
    record_cycle(const unsigned int cycle) override;
    void
    write_tables() const override;

    // The three callbacks of semismooth Newton and their parts.
    VI::ResidualNorms
    residual(const TrilinosWrappers::MPI::Vector &X,
             TrilinosWrappers::MPI::Vector       &R) const;
    void
    equation_residual(const TrilinosWrappers::MPI::Vector &X,
                      TrilinosWrappers::MPI::Vector       &R) const;
    void
    setup_jacobian(const TrilinosWrappers::MPI::Vector &X);
    unsigned int
    solve_with_jacobian(const TrilinosWrappers::MPI::Vector &rhs,
                        TrilinosWrappers::MPI::Vector       &dX);
    void
    assemble_difference_matrix(const TrilinosWrappers::MPI::Vector &X);
    void
    condense_rhs(const TrilinosWrappers::MPI::Vector &rhs);
    unsigned int
    solve_condensed_system();
    void
    recover_cell_unknowns(const TrilinosWrappers::MPI::Vector &rhs,
                          TrilinosWrappers::MPI::Vector       &dX);
    /// eta_alg from the residuals of the two face systems, with ghosts
    /// (hho_solver.cc).
    double
    algebraic_estimate(const TrilinosWrappers::MPI::Vector &rho_s,
                       const TrilinosWrappers::MPI::Vector &rho_d) const;
    /// gamma_alg max(eta_disc, eta_lin) at the start of a Newton step.
    double
    algebraic_tolerance() const;

    void
    compute_local_matrices();

    // Index bookkeeping between the cells, the faces and the unknowns X.
    using CellIterator = typename DoFHandler<dim>::active_cell_iterator;
    CellIterator
    face_cell(const CellIterator &cell) const;
    /// The share of a face's imbalance that `cell` keeps (hho_estimate.cc):
    /// half on an interior face, all of it on a free boundary face (the
    /// rows of the clamped faces are 0) and on a half of a face between
    /// refinement levels, whose coarse side has no rows.
    static double
    imbalance_share(const CellIterator &cell, const unsigned int face)
    {
      if (cell->at_boundary(face))
        return 1.;
      if (cell->face(face)->has_children())
        return 0.;
      return cell->neighbor_is_coarser(face) ? 1. : 0.5;
    }
    types::global_dof_index
    face_unknown(const types::global_dof_index face_dof,
                 const unsigned int            alpha) const;
    types::global_dof_index
    face_dof(const types::global_dof_index face_unknown) const;
    /// The unknowns of a cell: those of its nodes (n_fields per node) and
    /// of both membranes on its faces.
    unsigned int
    n_local_unknowns() const;
    ArrayView<const types::global_dof_index>
    local_unknowns(const CellIterator &cell) const;

    /// What the shape of a cell determines: the local HHO matrices
    /// (static_condensation.h) and the Gram matrix of FE_DGP's basis.
    struct LocalMatrices
    {
      StaticCondensation::CellOperators operators;
      FullMatrix<double>                mass;
    };
    const LocalMatrices &
    local_matrices_of(const CellIterator &cell) const;

    /// The face unknowns of X from the traces of the cell polynomials.
    void
    set_face_unknowns_from_traces(TrilinosWrappers::MPI::Vector &X) const;

    const Parameters            parameters;
    const MPI_Comm              comm;
    const VI::Domain            domain;
    VI::MembraneData<dim>       data;
    VI::ComplementarityFunction C;

    parallel::distributed::Triangulation<dim> triangulation;
    std::unique_ptr<Mapping<dim>>             mapping;
    const unsigned int                        degree;

    // Cell space P_p (FE_DGP: numbers the cell nodes, and is the basis of
    // the finite element functions for output and errors) and face space
    // P_{p-1} (FE_FaceQ), each scalar: every node and every face DoF carries
    // the unknowns of both membranes.
    FE_DGP<dim>     cell_fe;
    FE_FaceQ<dim>   face_fe;
    DoFHandler<dim> cell_dof_handler;
    DoFHandler<dim> face_dof_handler;

    // Nodal basis at the contact nodes: nodal values = V (FE_DGP
    // coefficients), T = V^{-1}.
    FullMatrix<double> V, T;
    // The basis functions of FE_DGP(p) that span the space of G_K.
    std::vector<unsigned int> gradient_basis;

    // The unknowns X: cells [3 i + alpha] (node i; alpha = u1, u2,
    // multiplier), then faces [3 N_nodes + 2 j + alpha] (face DoF j; alpha =
    // u1, u2). Each process owns the unknowns of its nodes and face DoFs.
    IndexSet owned_nodes, relevant_nodes;
    IndexSet owned_faces, relevant_faces;
    IndexSet owned_system, relevant_system;
    /// Copies of owned vectors into ghosted ones of the three layouts (map
    /// and import built once per mesh).
    VI::GhostedCopy ghosted_nodes, ghosted_faces, ghosted_system;

    /// Face DoFs: those of the clamped boundary faces (fixed) and of the
    /// coarse faces between refinement levels (the projection of their
    /// halves, constrain_hanging_faces()).
    AffineConstraints<double>     face_constraints;
    AffineConstraints<double>     system_constraints; ///< their unknowns in X
    AffineConstraints<double>     hanging_unknowns;   ///< the coarse faces'
    TrilinosWrappers::MPI::Vector boundary_values;    ///< X with Pi_F g only
    types::global_dof_index       n_boundary_face_dofs = 0;
    types::global_dof_index       n_hanging_face_dofs  = 0;
    VI::ContactRows               contact_rows;
    std::vector<bool> active_rows; ///< of the last Newton linearisation

    // Per locally owned cell (by active_cell_index): the positions in X of
    // its unknowns (x1, x2, x3, y1, y2: 3 n_c + 2 n_f of them, the local
    // order of static_condensation.h), the shape it has, and the elimination
    // of its cell unknowns in the current Newton step. Per shape (the cells
    // that are translates of each other): the local matrices.
    std::vector<types::global_dof_index>             unknown_indices;
    std::vector<unsigned int>                        cell_shape;
    std::vector<LocalMatrices>                       local_matrices;
    std::vector<StaticCondensation::CellElimination> eliminations;

    TrilinosWrappers::MPI::Vector         load; ///< (f_alpha, phi_I)_K
    TrilinosWrappers::MPI::Vector         solution;
    mutable TrilinosWrappers::MPI::Vector ghosted_iterate;
    double                                load_norm        = 0;
    double                                multiplier_scale = 0;

    // Without static condensation: the Jacobian A = [E ; J_C].
    TrilinosWrappers::SparseMatrix system_matrix;
    // With it: the face systems of the mean (fixed on a mesh) and of the
    // difference of the membranes (static_condensation.h).
    TrilinosWrappers::SparseMatrix mean_matrix, difference_matrix;
    TrilinosWrappers::MPI::Vector  mean_rhs, difference_rhs;
    TrilinosWrappers::MPI::Vector  mean_update, difference_update;
    TrilinosWrappers::MPI::Vector  ghosted_mean_update,
      ghosted_difference_update;
    std::vector<std::vector<bool>> constant_modes;

    // Linear solvers of the current mesh (created in solve()).
    std::unique_ptr<JacobianSolver> mean_solver, jacobian_solver;

    // The discrete solution as FE_DGP functions (with ghosts).
    TrilinosWrappers::MPI::Vector u1_h, u2_h, gap_h, lambda_h;
    Vector<float>                 contact_fraction;
    /// The bound of the energy error of the cell polynomials on this mesh
    /// (Estimators/Enabled), with its parts.
    std::optional<VI::DGContactEstimate> last_estimate;

    /// Nonlinear solver/Strategy = adaptive: Newton stopped by the estimate
    /// of its iterates (the shared VI::AdaptiveStopping), CG by eta_alg <=
    /// algebraic_threshold (0: CG runs to its tolerance).
    struct Iterate
    {
      TrilinosWrappers::MPI::Vector X;
      unsigned int                  linear_iteration = 0;
    };
    typename VI::AdaptiveStopping<Iterate, VI::DGContactEstimate>::Hooks
                                                         stopping_hooks();
    VI::AdaptiveStopping<Iterate, VI::DGContactEstimate> stopping;
    double algebraic_threshold = 0;
    /// From eta_disc at the end of the last adaptive solve and its mesh's
    /// cells.
    VI::EtaDiscPrediction eta_disc_prediction;

    std::unique_ptr<parallel::distributed::
                      SolutionTransfer<dim, TrilinosWrappers::MPI::Vector>>
      solution_transfer;
  };
} // namespace StepHHO
