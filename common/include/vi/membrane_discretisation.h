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

#include <vi/contact_system.h>
#include <vi/geometry.h>
#include <vi/ghosted_copy.h>
#include <vi/multiplier_function.h>

#include <array>
#include <functional>
#include <memory>
#include <vector>

namespace VI
{
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

    /// Q_degree on `geometry` (its mapping of the same degree).
    MembraneDiscretisation(const Geometry     geometry,
                           const unsigned int degree,
                           const MPI_Comm     comm);

    /// The coarse mesh of the geometry, refined `refinements` times.
    void
    make_grid(const unsigned int refinements);

    /// The nodes of the current mesh: the cached mapping, the DoFs, the
    /// index sets of nodes and unknowns, the hanging node constraints and
    /// the layout of the solution's finite element functions.
    void
    distribute_nodes();

    /// The constraints of u1, u2 (hanging nodes and Dirichlet data g1, g2
    /// on the whole boundary) and of X (no multiplier on constrained nodes).
    void
    make_constraints(const dealii::Function<dim> &g1,
                     const dealii::Function<dim> &g2);

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
    /// p >= 2 (the multiplier's basis is dual to the nodal one); and the
    /// row X3_i = 0 of each constrained node, which has no contact row.
    void
    set_coupling(ContactSystem &contact_system,
                 const Vector  &lumped_mass) const;

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

  protected:
    const MPI_Comm comm;
    const Geometry geometry;

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
  using Discretisation::comm, Discretisation::geometry,                        \
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
  /* what is done on the mesh */                                               \
  using Discretisation::make_grid, Discretisation::distribute_nodes,           \
    Discretisation::make_constraints, Discretisation::reinit_matrices,         \
    Discretisation::make_vertex_dofs, Discretisation::assemble_cells;          \
  using Discretisation::set_coupling, Discretisation::potentials,              \
    Discretisation::residual_functions, Discretisation::make_solution_fields;
