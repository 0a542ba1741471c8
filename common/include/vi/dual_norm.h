#pragma once

#include <deal.II/base/index_set.h>
#include <deal.II/dofs/dof_handler.h>
#include <deal.II/fe/fe_q.h>
#include <deal.II/fe/mapping.h>
#include <deal.II/lac/affine_constraints.h>
#include <deal.II/lac/trilinos_precondition.h>
#include <deal.II/lac/trilinos_sparse_matrix.h>
#include <deal.II/lac/trilinos_vector.h>

#include <vi/flux_reconstruction.h>

#include <functional>
#include <vector>

namespace VI
{
  /**
   * A guaranteed upper bound of the dual norm
   *
   *   ||m||_{-1} = sup over v in H^1_0(Omega) of (m, v) / ||grad v||
   *
   * of a function m in Q_p on every cell (cellwise constant, or a finite
   * element function of degree p), by equilibration: z_h in Q1 with
   * zero boundary values solves (grad z_h, grad v_h) = (m, v_h) (CG + AMG),
   * and the flux reconstruction of the problem equilibrates the source m
   * with the flux grad z_h, each vertex a carrying the constant c_a = -r_a /
   * (psi_a, 1) of the algebraic residual r_a of z_h (so that the patch
   * problems are compatible). Its flux rho in RT_p has div rho = m + c_h,
   * c_h = sum_a c_a psi_a, cell by cell, and for v in H^1_0
   *
   *   (m, v) = -(rho, grad v) - (c_h, v) <= (||rho|| + C_F ||c_h||) ||grad v||.
   *
   * The bound is the smaller of that and the Friedrichs bound C_F ||m||.
   * Where m lives on a band of width delta (the negative part of a Newton
   * iterate's multiplier lives on a ring of cells at the edge of the active
   * set), ||m||_{-1} is of order delta^(1/2) ||m||, and the Friedrichs
   * bound overestimates it by a factor of order delta^(-1/2)
   * (doc/estimators.md).
   *
   * Per mesh: the Q1 degrees of freedom, the Laplacian and its AMG; per
   * bound: one CG solve, one flux reconstruction and two cell loops (on
   * the threads of MultithreadInfo). On any number of processes
   * (collective calls).
   */
  template <int dim>
  class DualNormBound
  {
  public:
    /// The reconstruction (prepared for the mesh) must outlive this object.
    DualNormBound(const dealii::Mapping<dim>    &mapping,
                  const FluxReconstruction<dim> &reconstruction,
                  const double                   friedrichs_constant);

    /// Set up for the mesh of the reconstruction's last reinit().
    void
    reinit(const dealii::Triangulation<dim> &triangulation);

    /**
     * The bound of ||m||_{-1} for m = m_K on the cell of active index K
     * (read on the locally owned cells). Collective; zero if m vanishes on
     * every process.
     */
    double
    bound(const std::vector<double> &m) const;

    /**
     * The same for several m given at the points of the reconstruction's
     * quadrature, (*values[k])[K n_q + q] on the cell of active index K, m in
     * Q_p on every cell (e.g. a finite element function of the problem's
     * degree), so that the equilibration is exact. One Poisson solve per m,
     * one reconstruction for all (a field each).
     */
    std::vector<double>
    bounds_at_points(
      const std::vector<const std::vector<double> *> &values) const;

  private:
    /// m(K, q): a source at point q of the reconstruction's quadrature on
    /// the cell of active index K.
    using Source = std::function<double(unsigned int, unsigned int)>;

    std::vector<double>
    equilibrate(const std::vector<Source> &m) const;

    const dealii::Mapping<dim>       &mapping;
    const FluxReconstruction<dim>    &reconstruction;
    const double                      friedrichs_constant;
    dealii::FE_Q<dim>                 fe;
    dealii::DoFHandler<dim>           dof_handler;
    dealii::IndexSet                  relevant; ///< locally relevant Q1 dofs
    dealii::AffineConstraints<double> constraints;
    dealii::TrilinosWrappers::SparseMatrix       laplacian;
    dealii::TrilinosWrappers::PreconditionAMG    amg;
    dealii::TrilinosWrappers::MPI::Vector        hat_integrals; ///< (psi_a, 1)
    std::vector<dealii::types::global_dof_index> vertex_dofs;
  };
} // namespace VI
