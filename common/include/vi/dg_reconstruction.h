#pragma once

#include <deal.II/base/function.h>
#include <deal.II/base/index_set.h>
#include <deal.II/base/quadrature.h>
#include <deal.II/base/tensor.h>
#include <deal.II/dofs/dof_handler.h>
#include <deal.II/fe/fe_system.h>
#include <deal.II/fe/fe_values.h>
#include <deal.II/fe/mapping.h>
#include <deal.II/lac/affine_constraints.h>
#include <deal.II/lac/trilinos_vector.h>

#include <memory>
#include <vector>

namespace VI
{
  class Domain;

  /**
   * The lifting of the jumps of a broken function u_h (with the Dirichlet
   * data g on the boundary): on every cell K, L_K in
   *
   *   V(K) = { J_K^{-T} tau^ : tau^ in Q_p(K^)^dim }
   *
   * (covariant Piola images of the reference polynomials) with
   *
   *   (L_K, tau)_K = sum_{F in faces of K} w_F (tau . n_K, [[u_h]]_K)_F
   *                  for all tau in V(K),
   *
   * [[u_h]]_K = u_h|K - u_h|K' on an interior face (K' the neighbour;
   * where the neighbours across a face of K are refined, F runs over the
   * subfaces and K' over the children there),
   * u_h|K - g on a boundary face; w_F = 1/2 inside, 1 on the boundary.
   * Summed over the cells, (L, tau) = sum_F ({tau}.n_F, [[u_h]])_F for every
   * broken tau in V = prod_K V(K), the face terms of the interior penalty
   * forms. V(K) contains the gradient of every mapped Q_p function on K (the
   * covariant transformation is how gradients map), in particular grad
   * psi_a of the hat functions on any (also non-affine) cell: this is what
   * makes the equilibrated flux reconstruction of a dG solution compatible
   * (doc/step-membranes.md, dG section).
   *
   * The Gram matrix of V(K) and the face terms are computed with the given
   * quadratures; they must be those of the dG assembly and of the flux
   * reconstruction for the identity above to hold to round-off.
   */
  template <int dim>
  class JumpLifting
  {
  public:
    using CellIterator =
      typename dealii::Triangulation<dim>::active_cell_iterator;
    using Vector = dealii::TrilinosWrappers::MPI::Vector;

    JumpLifting(const dealii::Mapping<dim>        &mapping,
                const unsigned int                 degree,
                const dealii::Quadrature<dim>     &cell_quadrature,
                const dealii::Quadrature<dim - 1> &face_quadrature);

    /// Distribute the coefficients of V on the mesh of `triangulation`.
    void
    reinit(const dealii::Triangulation<dim> &triangulation);

    /**
     * The lifting of u_h (a ghosted vector on the broken DoFHandler
     * `broken`) with boundary data g, on the locally owned cells; `lifting`
     * is (re)initialised as a ghosted vector on get_dof_handler().
     */
    void
    compute(const dealii::DoFHandler<dim> &broken,
            const Vector                  &u,
            const dealii::Function<dim>   &g,
            Vector                        &lifting,
            const Domain                  *domain = nullptr) const;

    /// The FEValues that values() works with: one per thread.
    std::unique_ptr<dealii::FEValues<dim>>
    make_cell_values() const;

    /// L at the points of the cell quadrature on `cell` (owned or ghost),
    /// with `cell_values` from make_cell_values() as scratch.
    void
    values(const CellIterator                  &cell,
           const Vector                        &lifting,
           dealii::FEValues<dim>               &cell_values,
           std::vector<dealii::Tensor<1, dim>> &values) const;

    const dealii::DoFHandler<dim> &
    get_dof_handler() const;

  private:
    const dealii::Mapping<dim>       &mapping;
    const dealii::FESystem<dim>       fe;
    const dealii::Quadrature<dim>     cell_quadrature;
    const dealii::Quadrature<dim - 1> face_quadrature;
    dealii::DoFHandler<dim>           dof_handler;
    dealii::IndexSet                  owned_dofs, relevant_dofs;
  };


  /**
   * The Oswald (averaging) interpolation of a broken function into the
   * continuous Lagrange space of the same degree and nodes: at every node
   * of `continuous`, the mean of the values of u_h at that point over the
   * cells that share it; at the boundary nodes the value of g (when given),
   * so that s_h interpolates the Dirichlet data. The broken element must
   * have the nodes of the continuous one on every cell (FE_DGQArbitraryNodes
   * on the Gauss-Lobatto points for FE_Q). On meshes with hanging nodes
   * the values at the hanging nodes are then those the constraints
   * `hanging_nodes` (of `continuous`, on its locally relevant dofs) give,
   * so that s is conforming. `u` is ghosted, `s` has no ghosts.
   */
  template <int dim>
  void
  oswald_interpolation(
    const dealii::Mapping<dim>                  &mapping,
    const dealii::DoFHandler<dim>               &broken,
    const dealii::TrilinosWrappers::MPI::Vector &u,
    const dealii::DoFHandler<dim>               &continuous,
    const dealii::Function<dim>                 *g,
    dealii::TrilinosWrappers::MPI::Vector       &s,
    const Domain                                *domain        = nullptr,
    const dealii::AffineConstraints<double>     *hanging_nodes = nullptr);
} // namespace VI
