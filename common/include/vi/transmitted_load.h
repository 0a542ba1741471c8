#pragma once

#include <deal.II/base/quadrature.h>
#include <deal.II/dofs/dof_handler.h>
#include <deal.II/fe/mapping.h>
#include <deal.II/lac/affine_constraints.h>
#include <deal.II/lac/trilinos_vector.h>

#include <cstddef>
#include <cstdint>
#include <vector>

namespace VI
{
  /**
   * The load the contact transmits where the membranes move together, as
   * part of the estimate's multiplier (doc/reference.md, "A bound robust in
   * the tensions").
   *
   * Where u1 = u2 on an open set, the tension-weighted sum of the two
   * equations eliminates the Laplacian, and the multiplier is a function of
   * the data alone:
   *
   *   lambda = g := (mu1 f2 - mu2 f1) / (mu1 + mu2).
   *
   * The discrete multiplier lambda_h carries g only through its moments
   * against the hats; where the data jump across the free boundary, or
   * vary fast, the difference f1 + lambda_h is of the size of the data,
   * and the estimate divides it by mu1^(1/2): with mu1 << mu2 the bound
   * grows like (mu2 / mu1)^(1/2) and more. The estimate may use any
   * lambda~ with the moments of lambda_h against the vertex hats
   * (CellMultiplier), and this class splits it as
   *
   *   lambda~ = g 1_J + lambda~',   (lambda~', psi_a) = <lambda_h, psi_a>_h -
   * (g 1_J, psi_a),
   *
   * on a set J of cells with a node in the contact set. lambda~' is the
   * multiplier of the nodal moments m_i - G_i, G_i = (g 1_J, phi_i) (phi_i the
   * basis function of node x_i; since psi_a = sum_i psi_a(x_i) phi_i on the
   * cells of J, this takes (g 1_J, psi_a) off the moments against the hats). At
   * a converged iterate m_i - G_i = m (grad(u1h - u2h), grad phi_i) + (g
   * 1_(Omega \ J), phi_i) with m = mu1 mu2 / (mu1 + mu2), at every node (active
   * or not): of the size of the smaller tension. On J the residuals of the
   * membranes are then
   * f1 + g = mu1 (f1 + f2) / (mu1 + mu2) and f2 - g = mu2 (f1 + f2) /
   * (mu1 + mu2), each of the size of its own tension.
   *
   * The contact term 2 (lambda~, s~1 - s~2) asks for a cone
   * reconstruction without gap where g is large: the joined potentials
   * (join_at_nodes()) replace both values by their tension-weighted mean at
   * every node of a cell of J where the contact term of the nodal cone
   * reconstruction s_h, 2 (g^+, (s1 - s2)^+)_K, exceeds what joining costs
   * there, m |grad(s1 - s2)|_K^2. That changes only the gap, at the cost
   * m^(1/2) |grad (gap)| over the cells at the free boundary: of the size
   * of the error in the gap, whatever the tensions. On a mesh fitted to
   * the free boundary no cell is joined (the gap vanishes where g is
   * large); across cut cells, where the data jump, they are.
   *
   * On meshes with hanging nodes phi_i is the conforming basis function of
   * an unconstrained node (a hanging node's part of the moments goes to its
   * parents, as in the assembly), and joining a cell joins the parents of
   * its hanging nodes.
   */
  template <int dim>
  class TransmittedLoad
  {
  public:
    using Vector = dealii::TrilinosWrappers::MPI::Vector;

    /// What an iterate's estimate needs: J and the vertex moments G.
    struct Split
    {
      /// 1 on the locally owned cells of J, by active cell index.
      std::vector<std::uint8_t> joined_cells;
      /// G_i = (g 1_J, phi_i) at the nodes that carry a moment, on the
      /// locally owned nodes.
      Vector node_moments;
      /// 1 at the locally owned nodes of the cells of J, and of its joined
      /// cells.
      Vector load_nodes, joined_nodes;
    };

    /**
     * Per mesh: `no_moment` marks the nodes that carry no moment
     * (constrained ones); `quadrature` is that of the loads' values.
     */
    void
    reinit(const dealii::Mapping<dim>              &mapping,
           const dealii::DoFHandler<dim>           &dof_handler,
           const dealii::AffineConstraints<double> &no_moment,
           const dealii::Quadrature<dim>           &quadrature);

    /**
     * J and G for the tensions, the loads f1, f2 at the quadrature points
     * of the locally owned cells ([active cell index * n_q + q]) and the
     * contact indicator `contact` (> 0 at the nodes of the contact set),
     * and the nodes to join for the nodal cone reconstruction s1, s2 (all
     * three with ghost entries).
     */
    void
    split(const double               mu1,
          const double               mu2,
          const std::vector<double> &f1,
          const std::vector<double> &f2,
          const Vector              &contact,
          const Vector              &s1,
          const Vector              &s2,
          Split                     &split) const;

    /// g at one point.
    static double
    value(const double mu1, const double mu2, const double f1, const double f2)
    {
      return (mu1 * f2 - mu2 * f1) / (mu1 + mu2);
    }

    /// g at the g.size() quadrature points of the cell of active index
    /// `index`, from the loads tabulated as split() takes them.
    static void
    cell_values(const double               mu1,
                const double               mu2,
                const std::vector<double> &f1,
                const std::vector<double> &f2,
                const unsigned int         index,
                std::vector<double>       &g)
    {
      const std::size_t n_q = g.size();
      for (std::size_t q = 0; q < n_q; ++q)
        g[q] = value(mu1, mu2, f1[index * n_q + q], f2[index * n_q + q]);
    }

  private:
    const dealii::Mapping<dim>              *mapping     = nullptr;
    const dealii::DoFHandler<dim>           *dof_handler = nullptr;
    const dealii::AffineConstraints<double> *no_moment   = nullptr;
    dealii::Quadrature<dim>                  quadrature;
  };


  /**
   * The joined potentials: at the nodes where `joined` > 0, both values of
   * s1, s2 (locally owned vectors) replaced by their tension-weighted mean
   * (mu1 s1 + mu2 s2) / (mu1 + mu2); Dirichlet nodes must not be marked.
   */
  void
  join_at_nodes(const double                                 mu1,
                const double                                 mu2,
                const dealii::TrilinosWrappers::MPI::Vector &joined,
                dealii::TrilinosWrappers::MPI::Vector       &s1,
                dealii::TrilinosWrappers::MPI::Vector       &s2);
} // namespace VI
