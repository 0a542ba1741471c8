#pragma once

#include <deal.II/base/quadrature_lib.h>
#include <deal.II/distributed/tria.h>
#include <deal.II/dofs/dof_handler.h>
#include <deal.II/fe/fe_q.h>
#include <deal.II/fe/fe_values.h>
#include <deal.II/fe/mapping.h>
#include <deal.II/fe/mapping_q_cache.h>
#include <deal.II/lac/affine_constraints.h>
#include <deal.II/lac/trilinos_sparse_matrix.h>
#include <deal.II/lac/trilinos_vector.h>
#include <deal.II/meshworker/copy_data.h>
#include <deal.II/numerics/vector_tools_common.h>

#include <vi/cell_multiplier.h>
#include <vi/contact_system.h>
#include <vi/domain.h>
#include <vi/estimators.h>
#include <vi/ghosted_copy.h>
#include <vi/multiplier_function.h>
#include <vi/transmitted_load.h>

#include <array>
#include <functional>
#include <memory>
#include <vector>

namespace VI
{
  template <int dim>
  class FieldOutput;
  template <int dim>
  class FluxReconstruction;
  struct DomainParameters;
  struct DiscretizationParameters;
  struct EstimatorParameters;


  /**
   * An iterate X = (u1h, u2h, lambda_h) of the conforming membrane programs
   * as the estimators see it (finite element functions with ghosts): u_h,
   * its cone reconstruction s_h, lambda_h and its part from the nonnegative
   * coefficients, the algebraic residual r_h and the fluxes sigma_h
   * equilibrated with it.
   */
  struct MembraneIterate
  {
    using Vector = dealii::TrilinosWrappers::MPI::Vector;
    Vector       X;
    Vector       u1, u2, s1, s2, lambda, lambda_nonnegative, r1, r2;
    Vector       sigma1, sigma2;
    unsigned int linear_iteration = 0;
    /// With the cellwise multiplier (CellMultiplier): lambda_h and its part
    /// from the nonnegative coefficients on the cells (then `lambda` and
    /// `lambda_nonnegative` stay empty).
    std::vector<double> lambda_cells, lambda_nonnegative_cells;
    /// 2 <lambda_h, u1h - u2h>_h, the nodal complementarity of the iterate.
    double complementarity = 0;
    /// With the transmitted load (TransmittedLoad): g 1_J at the quadrature
    /// points of the owned cells.
    std::vector<double> transmitted_load;
  };


  /**
   * The conforming discretisation of two membranes in contact shared by
   * step-membranes and step-parabolic ([DMV20], [DMV20p]): Q_p on the mesh
   * of a geometry, the nodes and the node-interleaved unknowns
   * X = (X1, X2, X3) (NodalFields), the constraints of u1, u2 and X
   * (hanging nodes, Dirichlet data), the matrices of the contact system and
   * the cell assembly of the stiffness S, the loads (f_alpha, psi_i), the
   * lumped masses (1, psi_i) and, for p >= 2 or with a mass term (backward
   * Euler: E = mu_alpha S + M / dt), the mass matrix M.
   *
   * The programs derive from it: a membrane problem *is* a problem on this
   * discretisation, and its members keep the names the papers give them.
   * What differs between the programs is how the cell matrices enter the
   * blocks E of the system, which each program does in its own copier.
   */
  template <int dim>
  class MembraneDiscretisation
  {
  public:
    using Vector       = dealii::TrilinosWrappers::MPI::Vector;
    using CellIterator = typename dealii::DoFHandler<dim>::active_cell_iterator;

    /// Q_degree on `domain` (its mapping of the same degree), clamped where
    /// the domain says, its fluxes in RT_flux_degree: the two degrees choose
    /// the quadrature (FluxReconstruction::quadrature_points).
    MembraneDiscretisation(const Domain      &domain,
                           const unsigned int degree,
                           const unsigned int flux_degree,
                           const MPI_Comm     comm);

    /// The coarse mesh of the domain, refined `refinements` times.
    void
    make_grid(const unsigned int refinements);

    /// The nodes of the current mesh: the cached mapping, the DoFs, the
    /// index sets of nodes and unknowns, the hanging node constraints and
    /// the layout of the solution's finite element functions.
    void
    distribute_nodes();

    /// The constraints of u1, u2 (hanging nodes and Dirichlet data g1, g2
    /// on the clamped boundary) and of X (no multiplier on constrained
    /// nodes). With an `obstacle` (Model = obstacle) u2 is fixed to it at
    /// every node: membrane 1 then lies over the obstacle's interpolant;
    /// `smooth_obstacle`: Problem/Smooth obstacle (for the estimate).
    void
    make_constraints(const dealii::Function<dim> &g1,
                     const dealii::Function<dim> &g2,
                     const dealii::Function<dim> *obstacle        = nullptr,
                     const bool                   smooth_obstacle = false);

    /// The sparsity of the system matrix A (in `contact_system`), of S and,
    /// for p >= 2, of the Gram matrix M of the multiplier.
    void
    reinit_matrices(ContactSystem &contact_system);

    /// Global vertex index -> DoF of the vertex (the patch constants of the
    /// flux reconstruction for p = 1).
    void
    make_vertex_dofs();

    /// The cell matrices and vectors of the assembly. Matrices: stiffness
    /// (grad psi_j, grad psi_i), mass (psi_j, psi_i). Vectors: the loads
    /// (l1, psi_i), (l2, psi_i) and the lumped mass (1, psi_i).
    struct CellSystem : dealii::MeshWorker::CopyData<2, 3, 1>
    {
      CellSystem(const unsigned int n_dofs, const unsigned int n_q);
      /// l1, l2 at the quadrature points of the cell (a work array).
      std::vector<double> loads[2];
    };

    /// Fills the loads l1, l2 at the quadrature points of a cell (FEValues
    /// with the update flags asked for); called from several threads.
    using CellLoads = std::function<void(const CellIterator &,
                                         const dealii::FEValues<dim> &,
                                         std::vector<double> (&)[2])>;

    /// The cell integrals on the owned cells (MeshWorker::mesh_loop): the
    /// cell mass matrix with `mass_term` or p >= 2, the loads of
    /// `cell_loads` (with `load_flags` added to the FEValues). `copy_system`
    /// puts a cell's matrices into the program's system, in the order of
    /// the cells; the lumped masses (returned) and M (p >= 2, zeroed first)
    /// are assembled here through the hanging node constraints.
    Vector
    assemble_cells(const CellLoads                               &cell_loads,
                   const dealii::UpdateFlags                      load_flags,
                   const bool                                     mass_term,
                   const std::function<void(const CellSystem &)> &copy_system);

    /// The coupling D: lumped masses (psi_i, 1) for p = 1, the identity for
    /// p >= 2 (the multiplier's basis is dual to the nodal one); the row
    /// X3_i = 0 of each constrained node, which has no contact row; and the
    /// gap stiffness of the continuation with the tension of the gap,
    /// mu1 mu2 / (mu1 + mu2), or mu1 over an obstacle.
    void
    set_coupling(ContactSystem &contact_system,
                 const Vector  &lumped_mass,
                 const double   mu1,
                 const double   mu2) const;

    /// The potentials u1h, u2h of X, conforming (a GMRES iterate need not
    /// satisfy the hanging node constraints; its conforming version has
    /// the same residual in the condensed rows), and their reconstruction
    /// s1, s2 in the cone (averaged where u1h < u2h, hanging nodes following
    /// their parents): owned in `owned`, with ghosts in `ghosted` (both in
    /// the order u1, u2, s1, s2).
    void
    potentials(const Vector &X,
               const double  mu1,
               const double  mu2,
               Vector (&owned)[4],
               const std::array<Vector *, 4> &ghosted) const;

    /// The algebraic residual r_h of X as two functions (with ghosts):
    /// <r_alpha,h, psi_i>_h = (F - E X) in the rows of u_alpha, zero on the
    /// constrained nodes.
    void
    residual_functions(const ContactSystem      &contact_system,
                       const MultiplierFunction &multiplier_function,
                       const Vector             &X,
                       Vector                   &r1,
                       Vector                   &r2) const;

    /// The solution X as finite element functions u1_h, u2_h, gap_h,
    /// lambda_h and the indicator contact_set of its contact nodes; returns
    /// their number.
    dealii::types::global_dof_index
    make_solution_fields(const ContactSystem      &contact_system,
                         const MultiplierFunction &multiplier_function,
                         const Vector             &X);

    /// lambda_h from the multiplier coefficients of the contact rows of
    /// `contact_system` on this discretisation (matrices by reference: they
    /// follow the mesh).
    MultiplierFunction
    make_multiplier_function(const ContactSystem &contact_system) const;

    /// The VTU output of the solution's fields u1_h, u2_h, gap_h, lambda_h
    /// and contact_set.
    FieldOutput<dim>
    solution_output() const;

    /// |exact - uh| in `norm` over the domain (integrated with p + 3 Gauss
    /// points per direction).
    double
    global_error(const Vector                       &uh,
                 const dealii::Function<dim>        &exact,
                 const dealii::VectorTools::NormType norm) const;

    /// f1, f2 at the points of `quadrature` on the owned cells into
    /// load_values (for the assembly, the fluxes and the estimates).
    void
    tabulate_loads(const dealii::Function<dim> &f1,
                   const dealii::Function<dim> &f2);

    /// The loads l_alpha = f_alpha - d_t u_alpha,h of a backward Euler step
    /// at the points of load_values.
    void
    loads_of_step(const Vector *const (&dt_u)[2],
                  std::vector<double> (&loads)[2]) const;

    /// The multiplier the estimates take on this mesh (after the flux
    /// reconstruction's reinit): lambda_h as a finite element function, or
    /// cellwise (CellMultiplier: p >= 2 and Estimators/Multiplier =
    /// contact cells), with the transmitted load of
    /// Estimators/Transmitted load (TransmittedLoad, cellwise also for
    /// p = 1, on the cells `boundary_cells` says).
    void
    setup_estimate_multiplier(
      const EstimatorParameters                         &parameters,
      const double                                       mu1,
      const double                                       mu2,
      const dealii::Quadrature<dim>                     &points,
      const typename TransmittedLoad<dim>::BoundaryCells boundary_cells =
        TransmittedLoad<dim>::BoundaryCells::by_cost);

    /// Whether the estimate's multiplier depends on the contact set (the
    /// cellwise multiplier, the transmitted load).
    bool
    multiplier_needs_contact_set() const
    {
      return cell_multiplier || transmitted_load;
    }

    /// The indicator (with ghosts) of the nodes in the contact set of X.
    void
    contact_nodes(const ContactSystem &contact_system,
                  const Vector        &X,
                  Vector              &indicator) const;

    /// lambda_h of X as the estimate takes it into `it`: it.lambda and
    /// it.lambda_nonnegative, or the cellwise ones and
    /// it.complementarity, and g 1_J. `owned` holds u1h, u2h, s1, s2 of X
    /// (potentials()); `contact` indicates the contact set the cellwise
    /// multiplier and J follow, `loads` are the loads of the balance
    /// equations at the points of load_values (load_values itself for a
    /// steady problem).
    void
    describe_multiplier(const ContactSystem      &contact_system,
                        const MultiplierFunction &multiplier_function,
                        const Vector             &X,
                        const Vector (&owned)[4],
                        const Vector &contact,
                        const std::vector<double> (&loads)[2],
                        const double     mu1,
                        const double     mu2,
                        MembraneIterate &it) const;

    /// The fluxes sigma_alpha ~ -mu_alpha grad u_alpha,h of `it`,
    /// equilibrated with f_alpha - d_t u_alpha,h -/+ lambda~ - r_alpha,h
    /// into it.sigma1, it.sigma2 (lambda~ the multiplier of
    /// describe_multiplier()). The loads (load_values) and the discrete time
    /// derivative (`dt_u`, null for a steady problem) enter at the
    /// quadrature points, as in the assembly, so that the patch problems
    /// stay compatible; for p = 1 the residual enters each patch as the
    /// constant of its vertex (lumping), and so does lambda_h when it is
    /// not cellwise.
    void
    equilibrate_fluxes(const FluxReconstruction<dim> &fluxes,
                       const double                   mu1,
                       const double                   mu2,
                       const Vector *const (&dt_u)[2],
                       MembraneIterate &it) const;

    /// The estimators' input (VI::estimate_contact_error) for the iterate
    /// `it` with the look-ahead `ahead` on this discretisation, with the
    /// fluxes of `fluxes`: the data (mu, f, g, Friedrichs' constant) and
    /// the options are the program's. `Iterate` has the members of
    /// MembraneIterate.
    template <class Iterate>
    ContactEstimatorInput<dim>
    estimator_input(const FluxReconstruction<dim> &fluxes,
                    const Iterate                 &it,
                    const Iterate                 &ahead) const
    {
      ContactEstimatorInput<dim> in = discretisation_input(fluxes);
      in.u1                         = &it.u1;
      in.u2                         = &it.u2;
      in.s1                         = &it.s1;
      in.s2                         = &it.s2;
      in.lambda                     = &it.lambda;
      in.lambda_nonnegative         = &it.lambda_nonnegative;
      in.sigma1_disc                = &it.sigma1;
      in.sigma2_disc                = &it.sigma2;
      in.mass_lumped                = fe.degree == 1;
      in.obstacle                   = obstacle;
      in.smooth_obstacle            = smooth_obstacle;
      in.complementarity            = it.complementarity;
      in.lambda_ahead               = &ahead.lambda;
      in.f1_values                  = &load_values[0];
      in.f2_values                  = &load_values[1];
      if (cell_multiplier)
        {
          in.cell_multiplier          = cell_multiplier.get();
          in.lambda_cells             = &it.lambda_cells;
          in.lambda_nonnegative_cells = &it.lambda_nonnegative_cells;
          in.lambda_ahead_cells       = &ahead.lambda_cells;
        }
      if (transmitted_load)
        {
          in.transmitted_load       = &it.transmitted_load;
          in.transmitted_load_ahead = &ahead.transmitted_load;
        }
      in.r1_ahead     = &ahead.r1;
      in.r2_ahead     = &ahead.r2;
      in.sigma1_ahead = &ahead.sigma1;
      in.sigma2_ahead = &ahead.sigma2;
      return in;
    }

  private:
    /// What the estimators take from the discretisation: the mapping, the
    /// potential's DoFs, the fluxes' DoFs, quadrature and Piola signs.
    ContactEstimatorInput<dim>
    discretisation_input(const FluxReconstruction<dim> &fluxes) const;

  protected:
    const MPI_Comm comm;
    const Domain   domain;
    /// The obstacle of Model = obstacle (set by make_constraints()), or null.
    const dealii::Function<dim> *obstacle        = nullptr;
    bool                         smooth_obstacle = false;

    dealii::parallel::distributed::Triangulation<dim> triangulation;
    /// The geometry's mapping, and the one used everywhere: its support
    /// points cached once per mesh (on the disk the transfinite manifold is
    /// expensive to evaluate cell by cell).
    std::unique_ptr<dealii::Mapping<dim>>       geometry_mapping;
    std::unique_ptr<dealii::MappingQCache<dim>> mapping;
    dealii::FE_Q<dim>                           fe;
    dealii::DoFHandler<dim>                     dof_handler;
    /// One quadrature for the loads, the mass matrix, the flux
    /// reconstruction and the estimators, so that the patch problems are
    /// exactly compatible with the discrete equations (see
    /// FluxReconstruction::quadrature_points).
    dealii::QGauss<dim> quadrature;

    // Nodes (scalar DoFs) and the node-interleaved unknowns X.
    dealii::IndexSet owned_nodes, relevant_nodes;
    /// Copies owned node vectors into ghosted ones (map and import built
    /// once per mesh).
    GhostedCopy      ghosted_nodes;
    dealii::IndexSet owned_system, relevant_system;

    dealii::AffineConstraints<double> hanging_node_constraints;
    dealii::AffineConstraints<double> u1_constraints, u2_constraints;
    dealii::AffineConstraints<double> system_constraints;

    /// The scalar matrix of the AMG preconditioner (S, or S + M / (mu dt)).
    dealii::TrilinosWrappers::SparseMatrix stiffness_matrix;
    /// The L2 Gram matrix, p >= 2.
    dealii::TrilinosWrappers::SparseMatrix mass_matrix;
    /// Global vertex index -> DoF of the vertex (make_vertex_dofs()).
    std::vector<dealii::types::global_dof_index> vertex_dofs;
    /// f1, f2 at the points of `quadrature` (the flux quadrature) of the
    /// owned cells, [active cell index * n_q + q] (tabulate_loads()).
    std::vector<double> load_values[2];
    /// The multiplier of the estimate on the contact cells, and the
    /// transmitted load (setup_estimate_multiplier(); null if not used).
    std::unique_ptr<CellMultiplier<dim>>  cell_multiplier;
    std::unique_ptr<TransmittedLoad<dim>> transmitted_load;

    // The discrete solution as finite element functions (with ghosts).
    Vector u1_h, u2_h, gap_h, lambda_h, contact_set;
  };
} // namespace VI


/**
 * The members of VI::MembraneDiscretisation<dim> by their own names in a
 * class template derived from it: the base depends on `dim`, so its names
 * are found only through using-declarations (or this->). One list, for
 * both programs.
 */
#define VI_MEMBRANE_DISCRETISATION_MEMBERS(dim)                                \
  using Discretisation = VI::MembraneDiscretisation<dim>;                      \
  /* the mesh and the elements */                                              \
  using Discretisation::comm, Discretisation::domain,                          \
    Discretisation::triangulation, Discretisation::geometry_mapping,           \
    Discretisation::mapping, Discretisation::fe, Discretisation::dof_handler,  \
    Discretisation::quadrature;                                                \
  /* the nodes, the unknowns and their constraints */                          \
  using Discretisation::owned_nodes, Discretisation::relevant_nodes,           \
    Discretisation::ghosted_nodes, Discretisation::owned_system,               \
    Discretisation::relevant_system, Discretisation::hanging_node_constraints; \
  using Discretisation::u1_constraints, Discretisation::u2_constraints,        \
    Discretisation::system_constraints;                                        \
  /* the matrices and the solution's functions */                              \
  using Discretisation::stiffness_matrix, Discretisation::mass_matrix,         \
    Discretisation::vertex_dofs, Discretisation::u1_h, Discretisation::u2_h,   \
    Discretisation::gap_h, Discretisation::lambda_h,                           \
    Discretisation::contact_set;                                               \
  /* the loads and the estimate's multiplier */                                \
  using Discretisation::load_values, Discretisation::cell_multiplier,          \
    Discretisation::transmitted_load, Discretisation::tabulate_loads,          \
    Discretisation::loads_of_step, Discretisation::setup_estimate_multiplier,  \
    Discretisation::multiplier_needs_contact_set,                              \
    Discretisation::contact_nodes, Discretisation::describe_multiplier;        \
  /* what is done on the mesh */                                               \
  using Discretisation::make_grid, Discretisation::distribute_nodes,           \
    Discretisation::make_constraints, Discretisation::reinit_matrices,         \
    Discretisation::make_vertex_dofs, Discretisation::assemble_cells;          \
  using Discretisation::set_coupling, Discretisation::potentials,              \
    Discretisation::residual_functions, Discretisation::make_solution_fields;  \
  using Discretisation::make_multiplier_function,                              \
    Discretisation::solution_output, Discretisation::global_error,             \
    Discretisation::equilibrate_fluxes, Discretisation::estimator_input;
