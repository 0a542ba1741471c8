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
   * J holds the contact cells and, among the cells with some nodes in the
   * contact set, those where leaving g out would cost the estimate more
   * than taking it in: the contact term 2 (g^+, (s1 - s2)^+)_K, and the
   * undershoot g^- where the loads pull the membranes apart (in a time
   * step, where d_t u_h < 0 at the free boundary). That comparison assumes
   * that lambda~ carries the cell mean of g on a cell left out, and weighs
   * the rest by (h_K / pi)^2 / m. A bound that takes the soft membrane's
   * load in L2 (step-parabolic) sees the whole misfit g - lambda~' on such
   * a cell instead, unweighted: with BoundaryCells::all every cell with a
   * node in the contact set goes into J.
   *
   * On meshes with hanging nodes phi_i is the conforming basis function of
   * an unconstrained node (a hanging node's part of the moments goes to its
   * parents, as in the assembly).
   *
   * In a time step of backward Euler the loads are f_alpha - d_t u_alpha,h:
   * the balance rows then carry the discrete time derivative, and g is
   * taken of those loads.
   */
  template <int dim>
  class TransmittedLoad
  {
  public:
    using Vector = dealii::TrilinosWrappers::MPI::Vector;

    /// What an iterate's estimate needs: g 1_J and its moments G.
    struct Split
    {
      /// g 1_J at the quadrature points of the locally owned cells,
      /// [active cell index * n_q + q]: zero off J.
      std::vector<double> values;
      /// G_i = (g 1_J, phi_i) at the nodes that carry a moment, on the
      /// locally owned nodes.
      Vector node_moments;
      /// 1 at the locally owned nodes of the cells of J.
      Vector load_nodes;
    };

    /// Which of the cells with some (not all) nodes in the contact set go
    /// into J: those where the estimate gains by it, or all of them.
    enum class BoundaryCells
    {
      by_cost,
      all
    };

    /**
     * Per mesh: `no_moment` marks the nodes that carry no moment
     * (constrained ones); `quadrature` is that of the loads' values;
     * `friedrichs_constant` that of the domain (the estimate's weight of
     * the multiplier's undershoots).
     */
    void
    reinit(const dealii::Mapping<dim>              &mapping,
           const dealii::DoFHandler<dim>           &dof_handler,
           const dealii::AffineConstraints<double> &no_moment,
           const dealii::Quadrature<dim>           &quadrature,
           const double                             friedrichs_constant,
           const BoundaryCells boundary_cells = BoundaryCells::by_cost);

    /**
     * J, g 1_J and G for the tensions, the loads l1, l2 at the quadrature
     * points of the locally owned cells ([active cell index * n_q + q]),
     * the contact indicator `contact` (> 0 at the nodes of the contact set)
     * and the nodal cone reconstruction s1, s2 (all three with ghost
     * entries).
     */
    void
    split(const double               mu1,
          const double               mu2,
          const std::vector<double> &l1,
          const std::vector<double> &l2,
          const Vector              &contact,
          const Vector              &s1,
          const Vector              &s2,
          Split                     &split) const;

    /// g at one point.
    static double
    value(const double mu1, const double mu2, const double l1, const double l2)
    {
      return (mu1 * l2 - mu2 * l1) / (mu1 + mu2);
    }

  private:
    const dealii::Mapping<dim>              *mapping     = nullptr;
    const dealii::DoFHandler<dim>           *dof_handler = nullptr;
    const dealii::AffineConstraints<double> *no_moment   = nullptr;
    dealii::Quadrature<dim>                  quadrature;
    double                                   friedrichs_constant = 0;
    BoundaryCells boundary_cells = BoundaryCells::by_cost;
  };
} // namespace VI
