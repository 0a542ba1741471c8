#pragma once

#include <deal.II/base/function.h>
#include <deal.II/base/quadrature.h>
#include <deal.II/dofs/dof_handler.h>
#include <deal.II/fe/mapping.h>
#include <deal.II/lac/trilinos_vector.h>

#include <vi/estimators.h>
#include <vi/interior_penalty.h>

namespace VI
{
  class Domain;

  /**
   * A posteriori estimate of a discontinuous Galerkin iterate of the
   * two-membrane problem (doc/step-membranes.md, dG section, has the
   * theorem). The error is measured in the dG energy norm
   *
   *   |||v|||_dG^2 = |||v|||_h^2 + |v|_J^2,
   *   |||v|||_h^2  = sum_K mu1 |grad v1|_K^2 + mu2 |grad v2|_K^2 (broken),
   *   |v|_J^2      = sum_alpha mu_alpha sum_F gamma_F / h_F |[[v_alpha]]|_F^2,
   *
   * with the scheme's penalty; for v = u - u_h, [[v]] = -[u_h] inside and
   * g - u_h on the boundary, so the jump part of the error is computable
   * and enters the estimate as it is. The members of ContactEstimate have
   * the meaning of the conforming case with u_h the broken iterate and s~
   * the cone reconstruction of its Oswald interpolate.
   */
  struct DGContactEstimate : public ContactEstimate
  {
    /// Guaranteed bound of the broken part |||u - u_h|||_h.
    double broken = 0;
    /// Its discretisation part: broken <= broken_disc + eta_lin + eta_alg
    /// (eta_disc adds the jumps to it in quadrature).
    double broken_disc = 0;
    /// |u_h|_J (= |u - u_h|_J): the jump part of the error.
    double jump = 0;
    /// sum_alpha mu_alpha |grad_h u_alpha,h - grad s_alpha|^2, the
    /// non-conformity of u_h against its Oswald interpolate (reported).
    double oswald = 0;
  };


  /// Of the shared data, u1, u2, lambda and lambda_nonnegative are on
  /// `broken`; s1, s2 on `continuous`: the Oswald interpolate with the
  /// nodal values of g on the boundary, averaged at the nodes where s1 < s2.
  template <int dim>
  struct DGContactEstimatorInput : ContactEstimatorData<dim>
  {
    const dealii::Mapping<dim>    *mapping    = nullptr;
    const dealii::DoFHandler<dim> *broken     = nullptr; ///< FE_DGQ
    const dealii::DoFHandler<dim> *continuous = nullptr; ///< FE_Q, same nodes
    const dealii::DoFHandler<dim> *flux       = nullptr; ///< RT_p
    /// The cell quadrature of the flux reconstruction (a tensor Gauss rule)
    /// and the face quadrature of the dG assembly.
    const dealii::Quadrature<dim>     *quadrature      = nullptr;
    const dealii::Quadrature<dim - 1> *face_quadrature = nullptr;
    const InteriorPenalty             *penalty         = nullptr;

    /// lambda is a nodal (lumped) representative of the discrete multiplier,
    /// for which (lambda, u1h - u2h) does not vanish exactly at a solution:
    /// the linearisation part of the contact term is then `complementarity`.
    bool mass_lumped = false;
    /// 2 <lambda_h, u1h - u2h>_h = 2 sum_I m_I (u1h - u2h)(x_I) over the
    /// nodes of every cell (m_I the moments of lambda_h), which vanishes
    /// with the discrete complementarity: Newton's part of the contact term
    /// (with mass_lumped).
    double complementarity = 0;

    using Vector = typename ContactEstimatorData<dim>::Vector;
    /// On `broken`: the algebraic residuals r_h.
    const Vector *r1 = nullptr, *r2 = nullptr;
    /// Optional, on `continuous`: the Oswald interpolates before the
    /// averaging at the nodes where s1 < s2. s - oswald vanishes once
    /// Newton has converged (the nodal complementarity holds at every node
    /// of every cell, and averages keep it): its part of eta_nonc1 is a
    /// linearisation term. Null: all of eta_nonc1 is discretisation (so
    /// with the transmitted load, whose joining at the contact cells also
    /// changes s and does not vanish with Newton's error).
    const Vector *oswald1 = nullptr, *oswald2 = nullptr;
    /// On `flux`: the equilibrated fluxes.
    const Vector *sigma1 = nullptr, *sigma2 = nullptr;
    /// Optional (TransmittedLoad): g 1_J at the points of `quadrature` on
    /// the locally owned cells, [active cell index * n_q + q], added to
    /// lambda and lambda_nonnegative (which then carry the rest of the
    /// moments).
    const std::vector<double> *transmitted_load = nullptr;
  };


  /// Evaluate the estimate (collective over the processes of the mesh).
  template <int dim>
  DGContactEstimate
  estimate_dg_contact_error(const DGContactEstimatorInput<dim> &input);


  /**
   * |v|_J of the broken pair (v1, v2) with boundary data (g1, g2): the jump
   * seminorm of the dG energy norm (collective).
   */
  template <int dim>
  double
  jump_seminorm(const dealii::Mapping<dim>                  &mapping,
                const dealii::DoFHandler<dim>               &broken,
                const dealii::Quadrature<dim - 1>           &face_quadrature,
                const InteriorPenalty                       &penalty,
                const double                                 mu1,
                const double                                 mu2,
                const dealii::TrilinosWrappers::MPI::Vector &v1,
                const dealii::TrilinosWrappers::MPI::Vector &v2,
                const dealii::Function<dim>                 &g1,
                const dealii::Function<dim>                 &g2,
                dealii::Vector<float>                       *cellwise = nullptr,
                const Domain                                *domain = nullptr);
} // namespace VI
