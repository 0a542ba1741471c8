#pragma once

#include <deal.II/base/function.h>
#include <deal.II/base/quadrature.h>
#include <deal.II/dofs/dof_handler.h>
#include <deal.II/fe/fe_values.h>
#include <deal.II/fe/mapping.h>
#include <deal.II/lac/trilinos_vector.h>
#include <deal.II/lac/vector.h>

#include <array>
#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <utility>
#include <vector>

namespace VI
{
  class Domain;

  template <int dim>
  class CellMultiplier;
  template <int dim>
  class DualNormBound;

  /**
   * A posteriori error estimate of an iterate of the two-membrane problem
   * (doc/estimators.md has the theorem and its proof). All global numbers
   * are for the whole domain (summed over processes); the cellwise arrays
   * are indexed by active_cell_index and filled on locally owned cells.
   */
  struct ContactEstimate
  {
    /// Whether every term was computed (see
    /// ContactEstimatorInput::without_fluxes).
    bool complete = true;
    /// Guaranteed upper bound of |||u - u_h|||.
    double eta = 0;
    /// Components with eta <= eta_disc + eta_lin + eta_alg.
    double eta_disc = 0, eta_lin = 0, eta_alg = 0;

    // Ingredients.
    double eta_1      = 0; ///< {sum (eta_F + eta_R)^2}^(1/2) + remainder
    double eta_1_disc = 0; ///< {sum (eta_F,disc + eta_R)^2}^(1/2)
    double flux_disc  = 0; ///< {sum eta_F,disc^2}^(1/2)
    double residual   = 0; ///< {sum eta_R^2}^(1/2)
    double flux_alg   = 0; ///< |mu^(-1/2) sigma_alg|
    double remainder  = 0; ///< algebraic remainder (global Friedrichs)
    /// Over an obstacle: eta_1 with grad s~ in place of grad u_h in the
    /// flux terms (the second bound, |||u - s~||| <= ...); 0 otherwise.
    double eta_1_cone  = 0;
    double nonc_1      = 0; ///< |||s~_h - u_h|||
    double nonc_1_disc = 0; ///< |||s~_h - s_h|||
    double nonc_1_lin  = 0; ///< |||s_h - u_h|||
    double nonc_2      = 0; ///< C |lambda_h^neg|
    double nonc_2_disc = 0;
    double nonc_2_lin  = 0;
    double nonc_3      = 0; ///< 2 C |lambda_h^pos| |||s~_h - u_h||| (reported)
    double contact_pos = 0; ///< sum_K eta_C^pos = 2 (lambda_h^pos, u1h - u2h)
    /// eta_C~ = 2 (lambda_h^pos, s~1 - s~2) = 2 (lambda_h^pos, (s1 - s2)^+),
    /// the contact term of the bound (<= eta_C^pos + eta_nonc3), and its
    /// discretisation and linearisation parts.
    double contact_cone = 0;
    double contact_disc = 0;
    double contact_lin  = 0;
    /// |||G|||: the lifting G of the boundary interpolation error g - I_h g
    /// (zero for data that are traces of the finite element space).
    double dirichlet = 0;
    /// Per membrane alpha (index alpha - 1), for the bounds of step-parabolic
    /// that take the load of one membrane in L2 instead of through its flux
    /// (doc/step-parabolic.md, "Loads in L2"): sum_K (eta_F,K + eta_R,K)^2
    /// with the look-ahead flux, |mu^(1/2) grad u_h|^2, the squared L2 norm
    /// of f - d_t u_h - (-1)^alpha lambda~ and that of the remainder. These
    /// and multiplier_l2_squared are computed for parabolic problems only
    /// (ContactEstimatorInput::dt_u1 set); zero for steady ones.
    std::array<double, 2> flux_residual_squared{}, energy_squared{},
      load_squared{}, remainder_squared{};
    /// |lambda~ - c_K lambda~^pos|^2 (L2): the part of the multiplier that
    /// nonc_2 bounds in H^-1, for the bounds that take it in L2.
    double multiplier_l2_squared = 0;

    // Cellwise indicators (squared norms, for output and marking).
    dealii::Vector<double> cell_flux;          ///< sum_alpha eta_F,K^2
    dealii::Vector<double> cell_residual;      ///< sum_alpha eta_R,K^2
    dealii::Vector<double> cell_algebraic;     ///< |mu^(-1/2) sigma_alg|_K^2
    dealii::Vector<double> cell_nonconformity; ///< |||s~_h - u_h|||_K^2
    dealii::Vector<double> cell_contact;       ///< eta_C~,K
    /// eta_K^2 = sum_alpha (eta_F + eta_R)^2 + |||s~ - u_h|||_K^2
    ///           + C^2 |lambda^neg|_K^2 + eta_C~,K + |||G|||_K^2: the local
    ///           indicator.
    dealii::Vector<double> cell_total;

    /// Zero cellwise indicators for a mesh of n_cells active cells.
    void
    reinit_cell_indicators(const unsigned int n_cells);

    /// An estimate without fluxes: not complete, and NaN in every term
    /// (and indicator) that needs them.
    void
    mark_unknown_terms();
  };


  /**
   * The cellwise indicators of an estimate as fields for DataOut
   * (DataOut::type_cell_data): eta, eta_flux, eta_residual, eta_algebraic,
   * eta_nonconformity (square roots of the squared indicators) and
   * eta_contact (the signed contact term). The returned fields must outlive
   * DataOut::build_patches().
   */
  std::vector<std::pair<std::string, dealii::Vector<float>>>
  cell_indicators(const ContactEstimate &estimate);


  /**
   * The data and the iterate that both contact estimators take (this one
   * and the dG one of dg_estimators.h): the tensions mu_alpha, the loads
   * f_alpha, the Dirichlet data g_alpha (with gradients), Friedrichs'
   * constant of the domain, u_alpha,h, s_alpha,h, lambda_h and its part
   * from the nonnegative multiplier coefficients.
   */
  template <int dim>
  struct ContactEstimatorData
  {
    double                       mu1 = 1, mu2 = 1;
    const dealii::Function<dim> *f1 = nullptr, *f2 = nullptr;
    const dealii::Function<dim> *g1 = nullptr, *g2 = nullptr;
    double                       friedrichs_constant = 0;
    /// Where the membranes are clamped (g_alpha is imposed); null: on the
    /// whole boundary.
    const Domain *domain = nullptr;
    /// Model = obstacle: the rigid obstacle psi in place of membrane 2
    /// (u2h, s2 and the cone's second member are psi itself at the points
    /// of the estimate, membrane 2 has no flux, residual or error, and the
    /// cone reconstruction moves membrane 1 only: theta = 1); null for two
    /// membranes.
    const dealii::Function<dim> *obstacle = nullptr;
    /// The obstacle is twice differentiable where u1h dips below it
    /// (Problem/Smooth obstacle): a third bound (stationary problems).
    bool smooth_obstacle = false;

    using Vector     = dealii::TrilinosWrappers::MPI::Vector;
    const Vector *u1 = nullptr, *u2 = nullptr;
    const Vector *s1 = nullptr, *s2 = nullptr;
    const Vector *lambda             = nullptr;
    const Vector *lambda_nonnegative = nullptr;

    /// The tensions, loads and boundary data of `data` (a MembraneData),
    /// the clamped boundary and Friedrichs' constant of `domain`.
    template <typename Data, typename DomainType>
    void
    set_problem(const Data &data, const DomainType &clamped)
    {
      mu1                 = data.mu1;
      mu2                 = data.mu2;
      f1                  = data.f1.get();
      f2                  = data.f2.get();
      g1                  = data.g1.get();
      g2                  = data.g2.get();
      friedrichs_constant = clamped.friedrichs_constant();
      domain              = &clamped;
    }
  };


  /**
   * What the estimate of an iterate (u1h, u2h, lambda_h) needs. The iterate's
   * own discretisation fluxes sigma_disc (equilibrated with its residual)
   * and those of a look-ahead iterate (the same iterate after nu further
   * linear-solver iterations, or the iterate itself) whose fluxes sigma
   * equilibrate f -/+ lambda_ahead - r_ahead: sigma_alg = sigma -
   * sigma_disc, and what the look-ahead leaves unbalanced (its residual r,
   * and the change of the multiplier) is the remainder, bounded with the
   * Friedrichs constant. Vectors are finite element functions with ghost
   * entries: potential-space ones on `potential`, flux ones on `flux`.
   * Of the shared data, s_h is the iterate averaged at the nodes where u1h
   * < u2h, and g1, g2 may be null (the data are exactly represented);
   * otherwise u_h carries their interpolant on the boundary, and the
   * estimate accounts for the difference with a lifting.
   */
  template <int dim>
  struct ContactEstimatorInput : ContactEstimatorData<dim>
  {
    const dealii::Mapping<dim>    *mapping    = nullptr;
    const dealii::DoFHandler<dim> *potential  = nullptr;
    const dealii::DoFHandler<dim> *flux       = nullptr;
    const dealii::Quadrature<dim> *quadrature = nullptr;
    /// The Piola signs of the flux element's functions on the locally owned
    /// cells, [active cell index * dofs per cell + i] (as
    /// FluxReconstruction::get_piola_signs() gives them): the fluxes are
    /// evaluated from reference values and the Jacobians of the
    /// potential's FEValues, without a Raviart-Thomas FEValues per cell.
    const std::vector<std::int8_t> *flux_signs = nullptr;

    /// Optional: f1 and f2 at the points of `quadrature` on the locally
    /// owned cells, [active cell index * n_q + q] (tabulated once per mesh,
    /// they spare every estimate the evaluation of the load functions).
    const std::vector<double> *f1_values = nullptr, *f2_values = nullptr;
    /// p = 1, mass lumping: the linearisation part of the contact term is
    /// `complementarity` (below).
    bool mass_lumped = true;

    using Vector              = typename ContactEstimatorData<dim>::Vector;
    const Vector *sigma1_disc = nullptr, *sigma2_disc = nullptr;

    /// Optional: the multipliers (lambda_h, its part from the nonnegative
    /// coefficients and the look-ahead's) as the cellwise functions of a
    /// CellMultiplier, [cell * 2^dim + v], instead of the finite element
    /// functions lambda, lambda_nonnegative and lambda_ahead.
    const CellMultiplier<dim> *cell_multiplier          = nullptr;
    const std::vector<double> *lambda_cells             = nullptr,
                              *lambda_nonnegative_cells = nullptr,
                              *lambda_ahead_cells       = nullptr;
    /// With mass lumping or the cellwise multiplier: the linearisation part
    /// of the contact term, 2 <lambda_h, u1h - u2h>_h = 2 sum_i m_i (u1h -
    /// u2h)(x_i), which vanishes with the discrete complementarity (at every
    /// node lambda_h or the gap is zero), but not on the smoothed path of
    /// the continuation or at Fischer-Burmeister's iterates: there it keeps
    /// Newton's complementarity error out of eta_disc.
    double complementarity = 0;

    /// Optional (TransmittedLoad): g 1_J, the part of the estimate's
    /// multiplier that the data carry on the cells J, at the points of
    /// `quadrature` on the locally owned cells, [active cell index * n_q +
    /// q], added to the multipliers above; and the look-ahead's (J depends
    /// on the iterate).
    const std::vector<double> *transmitted_load       = nullptr,
                              *transmitted_load_ahead = nullptr;

    // The look-ahead.
    const Vector *lambda_ahead = nullptr;
    const Vector *r1_ahead = nullptr, *r2_ahead = nullptr;
    const Vector *sigma1_ahead = nullptr, *sigma2_ahead = nullptr;

    /// Parabolic problems (null for steady ones): the discrete time
    /// derivatives d_t u_alpha,h = (u_alpha,h^n - u_alpha,h^(n-1)) / dt_n of
    /// the iterate and of the look-ahead, whose fluxes then equilibrate
    /// f - d_t u_ahead -/+ lambda_ahead - r_ahead. The residual estimator
    /// subtracts d_t u_ahead, and what the look-ahead changes,
    /// d_t u_ahead - d_t u, goes into the remainder.
    const Vector *dt_u1 = nullptr, *dt_u2 = nullptr;
    const Vector *dt_u1_ahead = nullptr, *dt_u2_ahead = nullptr;

    /// Optional: dual norms bounded by equilibration (DualNormBound)
    /// instead of Friedrichs' inequality |v| <= C_F |grad v|: for the cell
    /// means m of the multiplier's undershoots (MultiplierSplit),
    /// (m, w1 - w2) <= ||m||_{-1} |grad(w1 - w2)|, and for the look-ahead's
    /// remainders rho_alpha, (rho_alpha, w_alpha) <= ||rho_alpha||_{-1}
    /// |grad w_alpha|. Each bound is the smaller of the two.
    const DualNormBound<dim> *dual_norm = nullptr;
    bool dual_norm_undershoots = false, dual_norm_remainder = false;
    /// Optional, with dual_norm_remainder: whether the equilibrated bound of
    /// the remainder (a Poisson solve per field, one reconstruction) is
    /// worth computing, asked with the estimate whose remainder is bounded
    /// by Friedrichs' inequality. Both bounds are guaranteed; the sharper
    /// one can lower eta_alg to flux_alg at most, and eta_disc and eta_lin
    /// not raise: a stopping test that no sharper bound could pass need not
    /// pay for it. Empty: always.
    std::function<bool(const ContactEstimate &)> sharpen_remainder;

    /// Only the terms that need no equilibrated flux (the fluxes may be
    /// empty; the iterate must be its own look-ahead, and the undershoots
    /// are bounded with Friedrichs' inequality). The estimate is then
    /// incomplete: eta_lin without the cross term sqrt((eta_1 + eta_nonc2)
    /// eta_nonc1,lin), a lower bound of the complete estimate's, and
    /// eta_alg = the remainder with Friedrichs' inequality, an upper bound;
    /// eta, eta_disc, the flux terms, nonc_1 and nonc_1_disc, the contact
    /// terms but contact_lin, and the cellwise indicators are NaN. Only the
    /// cells where s_h differs from u_h (and for p >= 2 those in contact)
    /// are then evaluated in full; on the others the remainder and the
    /// multiplier's terms need only values.
    bool without_fluxes = false;
  };


  /**
   * The multiplier on one cell K, split as lambda_h = lambda^ + delta with
   * lambda^ = c_K lambda_h^pos >= 0 and
   *   c_K = max(mean_K lambda_h, 0) / mean_K lambda_h^pos  in [0, 1],
   * so that delta has mean m_K = 0 where mean_K lambda_h >= 0, and delta =
   * lambda_h, m_K = mean_K lambda_h < 0 elsewhere. For w in H^1_0 and
   * Poincare's inequality on convex K,
   *   -(delta, w1 - w2)_K <= h_K / pi |delta - m_K|_K |grad(w1 - w2)|_K
   *                          - (m_K, w1 - w2)_K,
   * so the undershoots of lambda_h cost a term of order h |lambda_h^neg|
   * where the cell mean is nonnegative, instead of C_F |lambda_h^neg|
   * (doc/estimators.md). Integrals by the quadrature given as JxW.
   */
  struct MultiplierSplit
  {
    double cone_factor         = 0; ///< c_K
    double oscillation_squared = 0; ///< |delta - m_K|_K^2
    double mean                = 0; ///< m_K (<= 0)
    double mean_squared        = 0; ///< m_K^2 |K|
  };

  MultiplierSplit
  split_multiplier(const std::vector<double> &lambda,
                   const std::vector<double> &JxW);


  /**
   * The points at which the Dirichlet lifting G (doc/estimators.md,
   * "Boundary data") reads u_h and g on the face `face` of the reference
   * cell: the points of the face that share the tangential coordinate of
   * the cell quadrature's points, a tensor-product Gauss rule of n_q points
   * in 2d (an error otherwise). Point k has the k-th 1d Gauss coordinate
   * along the face; the weights are unused.
   */
  template <int dim>
  dealii::Quadrature<dim>
  lifting_face_points(const unsigned int n_q, const unsigned int face);

  /**
   * Add the lifting of g - v_h from the boundary face `face` to G and its
   * gradient at the points of `cell_values` (reinitialised on the cell;
   * its quadrature a tensor-product Gauss rule, with inverse Jacobians):
   * delta_F(t) (1 - n) in the reference coordinates (t along F, n away from
   * it), delta_F = g - v_h on F. `face_values` are the FEValues of v_h's
   * element at lifting_face_points(n_q, face), reinitialised on the cell.
   */
  template <int dim>
  void
  add_face_lifting(const dealii::FEValues<dim>                 &cell_values,
                   const dealii::FEValues<dim>                 &face_values,
                   const unsigned int                           face,
                   const dealii::TrilinosWrappers::MPI::Vector &v,
                   const dealii::Function<dim>                 &g,
                   std::vector<double>                         &G,
                   std::vector<dealii::Tensor<1, dim>>         &grad_G);

  /**
   * The lifting G (with its gradient) of both membranes on `cell`: zero,
   * plus add_face_lifting() of g_a - v_a from each boundary face where
   * `domain` clamps the membranes (every boundary face if it is null), or
   * zero everywhere if g is null (the data are exactly represented).
   * `face_values[f]` are the FEValues of face f as for add_face_lifting(),
   * reinitialised here on `cell`.
   */
  template <int dim>
  void
  lift_boundary_data(
    const typename dealii::DoFHandler<dim>::active_cell_iterator &cell,
    const dealii::FEValues<dim>                                  &cell_values,
    const std::vector<std::unique_ptr<dealii::FEValues<dim>>>    &face_values,
    const dealii::TrilinosWrappers::MPI::Vector *const            v[2],
    const dealii::Function<dim> *const                            g[2],
    const Domain                                                 *domain,
    std::vector<double>                                           G[2],
    std::vector<dealii::Tensor<1, dim>>                           grad_G[2]);


  /// Evaluate the estimate (collective over the processes of the mesh).
  template <int dim>
  ContactEstimate
  estimate_contact_error(const ContactEstimatorInput<dim> &input);


  /**
   * s_h: at every node where u1h < u2h, both values are replaced by the
   * tension-weighted mean (mu1 u1 + mu2 u2) / (mu1 + mu2), elsewhere s = u
   * (vectors without ghosts, on the nodes of a Lagrange element).
   */
  void
  average_at_violated_nodes(const double                                 mu1,
                            const double                                 mu2,
                            const dealii::TrilinosWrappers::MPI::Vector &u1,
                            const dealii::TrilinosWrappers::MPI::Vector &u2,
                            dealii::TrilinosWrappers::MPI::Vector       &s1,
                            dealii::TrilinosWrappers::MPI::Vector       &s2);


  /**
   * 2 <lambda_h, u1h - u2h>_h = 2 sum_i m_i (u1h - u2h)(x_i) for the
   * moments m_i = <lambda_h, psi_i>_h and the nodal values of u1h, u2h
   * (owned vectors on the same nodes): zero once Newton has converged (and
   * at the iterates of Newton-min with exact solves, whose rows set one
   * factor to zero), not on the smoothed path of the continuation, at
   * Fischer-Burmeister's iterates or at inexact ones. Below 1e-12 of its
   * scale 2 sum |m_i| max |u_h| it is the rounding of a converged iterate,
   * and zero is returned (collective).
   */
  double
  nodal_complementarity(const dealii::TrilinosWrappers::MPI::Vector &moments,
                        const dealii::TrilinosWrappers::MPI::Vector &u1,
                        const dealii::TrilinosWrappers::MPI::Vector &u2);
} // namespace VI
