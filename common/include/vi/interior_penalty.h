#pragma once

#include <deal.II/dofs/dof_handler.h>
#include <deal.II/fe/fe_interface_values.h>
#include <deal.II/fe/fe_values.h>
#include <deal.II/grid/tria.h>
#include <deal.II/lac/full_matrix.h>
#include <deal.II/lac/vector.h>

#include <vi/spellings.h>

#include <functional>
#include <string>

namespace VI
{
  /// The variants of InteriorPenalty.
  enum class InteriorPenaltyMethod
  {
    sipg,
    nipg,
    iipg
  };

  /**
   * The interior penalty discontinuous Galerkin forms of -div(mu grad u) on
   * broken polynomials (the seed's A_h = sum_K (grad u, grad v)_K + delta_h),
   * with Dirichlet data g imposed weakly:
   *
   *   A_h(u, v) = sum_K (grad u, grad v)_K
   *             - sum_F ({grad u}.n_F, [v])_F
   *             + epsilon sum_F ({grad v}.n_F, [u])_F
   *             + sum_F (gamma_F / h_F) ([u], [v])_F,
   *
   *   G_h(v)    = sum_{F on the boundary} epsilon (grad v.n, g)_F
   *                                     + (gamma_F / h_F) (g, v)_F,
   *
   * over all faces F (interior and boundary). On an interior face shared by
   * K and K' with n_F pointing from K to K', [v] = v_K - v_K' and {w} =
   * (w_K + w_K') / 2; on a boundary face [v] = v and {w} = w. The scheme is
   * A_h(u_h, v) = (f, v) + G_h(v) for all broken v; u_h = g is not imposed
   * strongly. The three variants differ in epsilon:
   *
   * - SIPG, epsilon = -1: symmetric, adjoint consistent, coercive when the
   *   penalty is large enough (below);
   * - NIPG, epsilon = +1: not symmetric; A_h(v, v) = |grad_h v|^2 +
   *   sum_F gamma_F / h_F |[v]|_F^2 for every v, so it is coercive for every
   *   gamma_F > 0;
   * - IIPG, epsilon = 0: not symmetric, coercive for a penalty a quarter of
   *   SIPG's threshold.
   *
   * All three are consistent: the exact solution satisfies the scheme.
   *
   * **Penalty.** gamma_F = C p (p + 1), h_F = min(|K|, |K'|) / |F| (the
   * extent of the cells normal to F; |K| / |F| on the boundary), C =
   * "Discretization/Penalty". On rectangles, the 1D inverse inequality
   * |w(0)|^2 <= (q + 1)^2 / h |w|^2_(0,h) for w of degree q = p - 1 gives
   * |d_n v|^2_F <= p^2 / h_F |d_n v|^2_K for v in Q_p(K). Each cell has two
   * faces per direction and |{w}|^2 <= (|w_K|^2 + |w_K'|^2) / 2, so on a mesh
   * at least two cells across sum_F h_F / p^2 |{grad v}.n|_F^2 <= 3/2
   * |grad_h v|^2 (weight 1/2 + 1/2 per direction inside, 1/2 + 1 at the
   * boundary). With |v|_J^2 = sum_F gamma_F / h_F |[v]|_F^2, Cauchy-Schwarz
   * and Young give for SIPG
   *
   *   A_h(v, v) >= (1 - sqrt(3 p / (2 C (p + 1)))) (|grad_h v|^2 + |v|_J^2),
   *
   * coercive as soon as C (p + 1) / p > 3/2. The default C = 2 satisfies this
   * for every p with margin (C (p + 1) / p >= 2: the constant is at least
   * 1 - sqrt(3/4) = 0.13, and 0.39 for p = 1); IIPG has half the
   * consistency term and the threshold C (p + 1) / p > 3/8.
   */
  class InteriorPenalty
      : public SpeltChoice<InteriorPenalty, InteriorPenaltyMethod>
  {
  public:
    using Type = InteriorPenaltyMethod;

    /// The default of "Discretization/Penalty": C in gamma_F = C p (p + 1).
    static constexpr double default_penalty_constant = 2.;

    InteriorPenalty(const Type         type,
                    const double       penalty_constant,
                    const unsigned int degree);

    /// Parse "sipg", "nipg" or "iipg" (the .prm spelling of Method).
    static InteriorPenalty
    from_name(const std::string &name,
              const double       penalty_constant,
              const unsigned int degree);

    /// "sipg", "nipg" and "iipg" (the .prm spelling of Method): names(),
    /// name().
    static const Spellings<Type> &
    spellings();

    /// "SIPG", "NIPG" or "IIPG".
    std::string
    label() const;

    /// epsilon: -1 (SIPG), +1 (NIPG), 0 (IIPG).
    double
    symmetry() const;

    double
    penalty_constant() const;

    unsigned int
    degree() const;

    /// gamma_F / h_F for a face with normal extent h_F.
    double
    penalty(const double h_F) const;

    /**
     * h_F of face f of `cell`: min(|K|, |K'|) / |F| for an interior face
     * F between K and its neighbour K', |K| / |F| on the boundary. Where
     * the neighbour is refined, F is the subface `subface` and K' the
     * neighbour's child on it; where the neighbour is coarser, F is the
     * face of `cell`. Either way F is the face both sides integrate over,
     * and both sides get the same h_F: that of the finer cell.
     */
    template <int dim>
    static double
    normal_extent(
      const typename dealii::Triangulation<dim>::cell_iterator &cell,
      const unsigned int                                        face,
      const unsigned int subface = dealii::numbers::invalid_unsigned_int);

    /**
     * Reinitialise `interface` on each part of face f of `cell` (interior)
     * that the cell shares with one active neighbour, and call
     * `action(subface)` there: once for F itself (subface invalid) where
     * the neighbour is as fine or coarser, once per subface (the
     * neighbour's children) where it is refined. Cell 0 of `interface` is
     * `cell`, so the normal points out of it. Summing the parts seen from
     * every cell visits each interior face of the mesh twice, one-sided
     * integrals on matching points, as the loops of the estimators need.
     */
    template <int dim>
    static void
    for_each_face_part(
      dealii::FEInterfaceValues<dim>                               &interface,
      const typename dealii::DoFHandler<dim>::active_cell_iterator &cell,
      const unsigned int                                            face,
      const std::function<void(const unsigned int subface)>        &action);

    /// Add sum_q grad phi_i . grad phi_j JxW: the cell part of A_h.
    template <int dim>
    static void
    add_cell_matrix(const dealii::FEValuesBase<dim> &values,
                    dealii::FullMatrix<double>      &matrix);

    /**
     * Add the boundary face part of A_h, - (grad u.n, v) + epsilon (grad
     * v.n, u) + gamma_F / h_F (u, v), with (i, j) = (test v, trial u).
     */
    template <int dim>
    void
    add_boundary_matrix(const dealii::FEFaceValuesBase<dim> &values,
                        const double                         h_F,
                        dealii::FullMatrix<double>          &matrix) const;

    /// Add G_h(v) on a boundary face for the data values g at its points.
    template <int dim>
    void
    add_boundary_rhs(const dealii::FEFaceValuesBase<dim> &values,
                     const double                         h_F,
                     const std::vector<double>           &g,
                     dealii::Vector<double>              &rhs) const;

    /**
     * Add the interior face part of A_h, - ({grad u}.n, [v]) + epsilon
     * ({grad v}.n, [u]) + gamma_F / h_F ([u], [v]), over the interface dofs
     * (n = the normal of the first cell, [v] = v_first - v_second).
     */
    template <int dim>
    void
    add_face_matrix(const dealii::FEInterfaceValues<dim> &values,
                    const double                          h_F,
                    dealii::FullMatrix<double>           &matrix) const;

  private:
    double       penalty_constant_;
    unsigned int degree_;
  };
} // namespace VI
