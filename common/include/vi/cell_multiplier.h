#pragma once

#include <deal.II/base/index_set.h>
#include <deal.II/base/quadrature.h>
#include <deal.II/base/table.h>
#include <deal.II/dofs/dof_handler.h>
#include <deal.II/fe/mapping.h>
#include <deal.II/lac/affine_constraints.h>
#include <deal.II/lac/trilinos_vector.h>

#include <vector>

namespace VI
{
  /**
   * The multiplier of the estimate on the contact cells.
   *
   * The discrete multiplier acts on the potentials only through its
   * moments at the nodes: <lambda_h, v>_h = sum_i m_i v(x_i) over the
   * unconstrained nodes x_i (m_i = D_i X3_i). Its conforming representative
   * M^(-1) m is continuous: where the exact multiplier jumps across the
   * free boundary, it spreads into the first layer of cells outside the
   * contact set, where the gap is positive, and there its contact term
   * 2 (lambda_h^pos, u1h - u2h) is of order h^(3/2) per unit length of the
   * free boundary, above the error of p >= 2 (doc/estimators.md).
   *
   * The estimate needs less: a function lambda~ in L^2 with the moments of
   * lambda_h against the vertex hats, (lambda~, psi_a) = <lambda_h, psi_a>_h
   * (the compatibility of the patch problems of the flux reconstruction);
   * the guaranteed bound holds for any such lambda~. This class builds one
   * cell by cell:
   *
   * - at a hanging node x_j (constrained, x_j = sum_i c_ji x_i), the
   *   moments of its parents x_i carry its part too: m_i is the moment of
   *   the conforming basis function phi_i + sum_j c_ji phi_j. That part,
   *   M_j = (phi_j, 1) sum_i c_ji m_i / (phi_i + sum_k c_ki phi_k, 1) (the
   *   parents' densities interpolated at x_j), goes back to x_j: x_i keeps
   *   m_i - sum_j c_ji M_j. A parent gives up at most its own moment:
   *   G_i = sum_j c_ji M_j is scaled by alpha_i = m_i / G_i clamped to
   *   [0, 1] (less than 1 where the parents' densities differ much, at the
   *   free boundary; 0 where m_i has the other sign, e.g. a moment that
   *   is zero up to round-off), and M_j by the least alpha of its
   *   parents, so that lambda~ depends continuously on the moments.
   *   (Not where a parent is a Dirichlet node, which
   *   carries no moment to give up, nor where x_j has no contact cell and
   *   a parent has one: at the free boundary the moment stays on the
   *   contact cells, see below.) For a constant multiplier these are its
   *   moments against phi_i and phi_j, so that the rules below reproduce
   *   it on meshes with hanging nodes as well; without this, the coarse
   *   cells at a hanging face received the share of the fine ones, and
   *   the flux reconstruction carried the difference back (a flux
   *   indicator hundreds of times the error of an accurate contact cell);
   * - each moment m_i is shared among the cells K that carry node x_i, in
   *   proportion to |K| (phi^_i, 1)_K^ (the reference integral of the
   *   local shape function: the exact split of (lambda, phi_i) for a
   *   constant lambda on parallelograms), among the contact cells only
   *   (cells all of whose unconstrained nodes are in the contact set of
   *   the Newton step, where it enforces u1h = u2h) where x_i has one,
   *   among all of them where it has none;
   * - on K, lambda~ is the Q1 function whose moments against the 2^dim
   *   vertex functions psi_v of K are those of K's shares:
   *   (lambda~, psi_v)_K = sum_i share_(i,K) psi_v(x_i).
   *
   * Summing over the cells, (lambda~, psi_a) = sum_i m_i psi_a(x_i) =
   * <lambda_h, psi_a>_h for every conforming hat psi_a (on K it is a
   * combination of the psi_v, also at hanging nodes, where psi_a(x_j) =
   * sum_i c_ji psi_a(x_i) since psi_a is conforming). On a contact cell the
   * Newton iterate's gap vanishes at every node of K (exactly once the
   * linear system is solved), hence on K (Q_p), and so does the contact
   * term; a constant multiplier is reproduced on parallelograms.
   */
  template <int dim>
  class CellMultiplier
  {
  public:
    /**
     * Per mesh: the measures and the inverse Q1 mass matrices of the cells.
     * `no_moment` marks the nodes that carry no moment (constrained ones:
     * Dirichlet and hanging nodes); `quadrature` is where values() will
     * evaluate lambda~.
     */
    void
    reinit(const dealii::Mapping<dim>              &mapping,
           const dealii::DoFHandler<dim>           &dof_handler,
           const dealii::AffineConstraints<double> &no_moment,
           const dealii::Quadrature<dim>           &quadrature);

    /**
     * The Q1 coefficients of lambda~ on the locally owned cells,
     * [active cell index * 2^dim + v], from the moments m. The contact
     * cells are those whose nodes that carry a moment all have
     * `contact` > 0 (the nodes where the Newton step enforces u1h = u2h;
     * both vectors with ghost entries). The map from m to lambda~ is linear
     * for a given contact set.
     */
    void
    distribute(const dealii::TrilinosWrappers::MPI::Vector &moments,
               const dealii::TrilinosWrappers::MPI::Vector &contact,
               std::vector<double>                         &coefficients) const;

    /// lambda~ at the points of the quadrature of reinit() on a locally
    /// owned cell.
    void
    values(const std::vector<double> &coefficients,
           const unsigned int         active_cell_index,
           std::vector<double>       &values) const;

  private:
    static constexpr unsigned int n_vertices = 1U << dim;

    const dealii::DoFHandler<dim>           *dof_handler = nullptr;
    const dealii::AffineConstraints<double> *no_moment   = nullptr;
    dealii::IndexSet                         relevant;

    /// (phi^_i, 1) on the reference cell, for every local node i.
    std::vector<double> reference_weights;
    /// psi_v at the support point of local node i: [i][v].
    dealii::Table<2, double> vertex_function_at_node;
    /// psi_v at the quadrature points: [q][v].
    dealii::Table<2, double> vertex_function_at_point;
    /// |K| of locally owned and ghost cells, by active cell index.
    std::vector<double> measure;
    /// (phi_i, 1) and (phi_i + sum_j c_ji phi_j, 1) (the conforming basis
    /// function, at the nodes that carry a moment), with |K| (phi^_i, 1)^
    /// for (phi_i, 1)_K; on the locally relevant nodes.
    dealii::TrilinosWrappers::MPI::Vector node_integral, conforming_integral;
    /// The inverse Q1 mass matrix of each locally owned cell, row by row.
    std::vector<double> inverse_mass;
  };
} // namespace VI
