#pragma once

#include <deal.II/base/conditional_ostream.h>
#include <deal.II/base/convergence_table.h>
#include <deal.II/base/index_set.h>
#include <deal.II/base/parameter_handler.h>
#include <deal.II/base/quadrature_lib.h>
#include <deal.II/base/timer.h>
#include <deal.II/distributed/solution_transfer.h>
#include <deal.II/distributed/tria.h>
#include <deal.II/dofs/dof_handler.h>
#include <deal.II/fe/fe_dgq.h>
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
#include <vi/dg_estimators.h>
#include <vi/dg_reconstruction.h>
#include <vi/domain.h>
#include <vi/flux_reconstruction.h>
#include <vi/ghosted_copy.h>
#include <vi/interior_penalty.h>
#include <vi/linear_solvers.h>
#include <vi/semismooth_newton.h>
#include <vi/stationary_problem.h>
#include <vi/summary.h>
#include <vi/test_cases.h>

#include "membrane_problem.h"

#include <memory>
#include <optional>

namespace StepMembranes
{
  using namespace dealii;

  /**
   * The parameters the discontinuous Galerkin methods add to the section
   * Discretization: "Penalty", the constant C of gamma_F = C p (p + 1).
   */
  struct DGParameters
  {
    double penalty = VI::InteriorPenalty::default_penalty_constant;

    static void
    declare(ParameterHandler &prm);
    void
    parse(ParameterHandler &prm);
  };


  /**
   * Contact between two membranes with interior penalty discontinuous
   * Galerkin methods (SIPG, NIPG, IIPG; the seed's "The Discontinuous
   * Galerkin method"): find u1h, u2h in the broken space X_h^p = prod_K
   * Q_p(K) and lambda_h in Lambda_h^p with
   *
   *   mu1 A_h(u1h, v1) - <lambda_h, v1>_h = (f1, v1) + mu1 G_h1(v1),
   *   mu2 A_h(u2h, v2) + <lambda_h, v2>_h = (f2, v2) + mu2 G_h2(v2),
   *   (u1h - u2h)|K (x_I) >= 0, <lambda_h|K, psi_I>_h,K >= 0,
   *   <lambda_h, u1h - u2h>_h = 0,
   *
   * for all broken v and every node x_I of every cell K (its own support
   * points: the Gauss-Lobatto nodes of FE_DGQArbitraryNodes). A_h and the
   * weakly imposed Dirichlet data G_h are those of VI::InteriorPenalty.
   * Lambda_h^p is the broken Q_p with the cell-local basis dual to the nodal
   * basis for a bracket <.,.>_h: the L2 product of the cell for p >= 2 (the
   * slides' Lambda_h^p, (Theta_I, psi_J)_K = delta_IJ, D = I), the
   * mass-lumped one for p = 1 (X3 = nodal values of lambda_h >= 0, D =
   * diag((psi_I, 1)_K)), as the conforming method. The coupling block is
   * diagonal and the complementarity nodewise, the FEM structure
   *
   *   [mu1 S_h   0   -D] X = F,   X1 - X2 >= 0,  X3 >= 0,  (X1 - X2).X3 = 0,
   *   [0   mu2 S_h   +D]
   *
   * with the (for NIPG and IIPG nonsymmetric) dG stiffness S_h, solved by
   * the same semismooth Newton and linear solvers. With Dirichlet data
   * imposed weakly, every node of every cell carries a constraint pair.
   *
   * The a posteriori estimate (doc/step-membranes.md) reconstructs a
   * conforming potential by Oswald interpolation and an equilibrated flux
   * on vertex patches from the broken gradient and the lifting of the jumps.
   */
  template <int dim>
  class DGMembraneProblem : public VI::StationaryProblem
  {
  public:
    DGMembraneProblem(const Parameters   &parameters,
                      const DGParameters &dg_parameters,
                      ParameterHandler   &prm,
                      const MPI_Comm      comm);

  private:
    using Vector = TrilinosWrappers::MPI::Vector;
    /// An iterate as the adaptive stopping sees it: the estimate of a dG
    /// iterate takes its algebraic residual through Friedrichs' bound
    /// (eta_alg = remainder), with no look-ahead.
    struct Iterate
    {
      Vector       X;
      unsigned int linear_iteration = 0;
    };

    void
    check_parameters() const;
    /// GMRES with the contact AMG (Linear solver/Preconditioner = amg).
    bool
    uses_contact_amg() const;
    void
    check_data() const override;
    void
    make_grid() override;
    void
    setup_system() override;
    void
    assemble_system() override;
    /// The hooks of the adaptive stopping: this program's iterate and
    /// estimate.
    typename VI::AdaptiveStopping<Iterate, VI::DGContactEstimate>::Hooks
    stopping_hooks();
    /// mu_alpha a_h of a cell or face into the system (and a_h into the
    /// matrix of the contact AMG).
    void
    add_local_matrix(const FullMatrix<double>                   &local,
                     const std::vector<types::global_dof_index> &dofs);
    /// The coupling D, the row weights and the contact AMG (if used).
    void
    set_coupling_and_preconditioner(const Vector &coupling);
    void
    initialize_iterate() override;
    void
    solve() override;
    /// The Oswald interpolates of u, averaged at the violated nodes, and
    /// the liftings of the jumps (the potentials of the estimate).
    void
    reconstruct_potentials(const Vector (&u)[2],
                           Vector (&oswald)[2],
                           Vector (&averaged)[2],
                           Vector (&L)[2]) const;
    VI::DGContactEstimate
    estimate(const Vector &X) const;
    /// The multiplier of the estimate from the moments of lambda_h: the
    /// limited one, its part from the nonnegative moments and the function
    /// the fluxes equilibrate (the L2 representative; with the transmitted
    /// load of the contact set `contact`, returned as g 1_J, the cellwise Q1
    /// function of the vertex moments).
    std::vector<double>
    estimate_multiplier(Vector        moments,
                        const Vector *contact,
                        const Vector (&s)[2],
                        Vector &lambda,
                        Vector &lambda_nonnegative,
                        Vector &lambda_source) const;
    void
    join_at_contact_cells(const Vector &contact,
                          const Vector &moments,
                          Vector (&s)[2]) const;
    std::vector<double>
    transmitted_load(const Vector &contact,
                     const Vector (&s)[2],
                     Vector &G) const;
    void
    postprocess() override;
    void
    compute_errors() override;
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

    /**
     * The broken function v with (v, psi_I)_K = moments_I on every owned
     * cell K (v = M_K^{-1} moments, the dual basis); v is ghosted.
     */
    void
    function_from_moments(const Vector &moments, Vector &v) const;
    /// p = 1: the bracket <.,.>_h is mass-lumped (X3 = nodal values).
    bool
    mass_lumped() const;
    /// lambda_h (ghosted) from its dual coefficients X3 (no ghosts).
    void
    multiplier_function(const Vector &X3, Vector &lambda) const;
    /// The multiplier of the estimate from the moments <lambda_h, psi_I>_h:
    /// the nodal values of `function` (else m_I / (psi_I, 1)_K), limited
    /// towards the cell mean where, with the transmitted load `load` at the
    /// estimator's points if given, it is negative.
    void
    limited_function(const Vector              &moments,
                     const Vector              *function,
                     const std::vector<double> *load,
                     Vector                    &lambda) const;
    /// v[j]: the cellwise Q1 function with the moments against the vertex
    /// functions of <lambda_h, .>_h given by moments[j]; ghosted.
    void
    vertex_moment_functions(const std::vector<const Vector *> &moments,
                            const std::vector<Vector *>       &v) const;
    /// The inverse map: moments_I = (v, psi_I)_K; v ghosted, moments not.
    void
    moments_of_function(const Vector &v, Vector &moments) const;
    /// The loop of these cellwise maps: `local` on every owned cell, with
    /// the values and JxW of `quadrature` there and the cell's nodes.
    void
    for_each_owned_cell(
      const Quadrature<dim> &quadrature,
      const std::function<void(const FEValues<dim> &,
                               const std::vector<types::global_dof_index> &)>
        &local) const;

    const Parameters            parameters;
    const MPI_Comm              comm;
    const VI::Domain            domain;
    VI::MembraneData<dim>       data;
    VI::ComplementarityFunction C;
    const VI::InteriorPenalty   penalty;

    parallel::distributed::Triangulation<dim> triangulation;
    std::unique_ptr<Mapping<dim>>             geometry_mapping;
    std::unique_ptr<MappingQCache<dim>>       mapping;
    /// Broken Q_p on the Gauss-Lobatto nodes (those of FE_Q(p)).
    FE_DGQArbitraryNodes<dim> fe;
    DoFHandler<dim>           dof_handler;
    /// One cell and one face quadrature for assembly, flux reconstruction,
    /// lifting and estimators (compatibility of the patch problems).
    QGauss<dim>     quadrature;
    QGauss<dim - 1> face_quadrature;

    IndexSet owned_nodes, relevant_nodes;
    /// Copies owned node vectors into ghosted ones (map and import built
    /// once per mesh).
    VI::GhostedCopy ghosted_nodes;
    IndexSet        owned_system, relevant_system;

    /// A = [E ; J_C], F, the contact rows and the linear solvers.
    VI::ContactSystem contact_system;
    /// The scalar interior penalty matrix a_h (the block of membrane alpha
    /// is mu_alpha a_h), for the contact AMG (Preconditioner = amg only).
    dealii::TrilinosWrappers::SparseMatrix stiffness_matrix;
    Vector                                 solution; ///< X
    Vector lumped_mass;                              ///< (psi_I, 1)_K per node

    // The estimators: the continuous space of the potential reconstruction
    // (FE_Q(p), also deciding vertex ownership of the patches), the flux
    // reconstruction and the lifting of the jumps.
    FE_Q<dim>       fe_continuous;
    DoFHandler<dim> continuous_dof_handler;
    IndexSet        owned_continuous;
    IndexSet        relevant_continuous;
    /// The hanging node constraints of the continuous space: its functions
    /// (the potential reconstruction s_h) are conforming.
    AffineConstraints<double>                    continuous_hanging_nodes;
    std::unique_ptr<VI::FluxReconstruction<dim>> flux_reconstruction;
    std::unique_ptr<VI::JumpLifting<dim>>        lifting;

    // The discrete solution as finite element functions (with ghosts).
    Vector u1_h, u2_h, gap_h, lambda_h, contact_set;

    std::unique_ptr<parallel::distributed::SolutionTransfer<dim, Vector>>
      solution_transfer;

    /// The adaptive stopping of GMRES and Newton (and the records of every
    /// estimate of the solve).
    VI::AdaptiveStopping<Iterate, VI::DGContactEstimate> stopping;

    // What each cycle measured (beside the members of StationaryProblem).
    std::optional<VI::DGContactEstimate> final_estimate;
    double                               error_broken = 0;
    double                               error_jump   = 0;
  };
} // namespace StepMembranes
