#pragma once

// A posteriori error estimators of [BDMV20] for the finite volume scheme of
// finite_volume_scheme.h, distinguishing the discretisation, linearisation
// and algebraic errors, and the phase-transition estimator. Header-only:
// the unit tests use it directly. See doc/step-twophase.md for the formulas.

#include <deal.II/base/quadrature_lib.h>
#include <deal.II/fe/fe_q.h>

#include "finite_volume_scheme.h"

#include <array>
#include <cmath>
#include <vector>

namespace StepTwoPhase
{
  /// The estimators of one iterate, summed over the cells and the two
  /// components and integrated over the time step (see Estimators).
  struct EstimatorValues
  {
    double disc = 0.; ///< eta_disc = flux + nonconformity estimators
    double lin  = 0.; ///< eta_lin, with the phase-equilibrium part below
    double alg  = 0.; ///< eta_alg
    double flux = 0.; ///< the flux estimators alone
    double nonconformity    = 0.; ///< the nonconformity estimators alone
    double equilibrium      = 0.; ///< the phase-equilibrium part of eta_lin
    double phase_transition = 0.; ///< eta_C, m s
  };


  /**
   * Estimators at an iterate U = U^{n,k,i} (time step n, Newton step k,
   * linear solver iteration i) linearised at U^{n,k-1}, over the time
   * interval I_n = (t^{n-1}, t^n) of length dt.
   *
   * *Reconstructions.* The fields p in {P^l, P^g, chi} are piecewise
   * constant. Their discrete gradients g_sigma on the faces (two-point
   * differences; at x = L to the Dirichlet state; at x = 0 those for which
   * the fluxes of the reconstructed fields equal the data, with grad P^g =
   * grad P^l) define a continuous piecewise linear gradient; p_hat in
   * P2(T_h) has this gradient in each cell and the cell value as mean
   * (the P2 reconstruction). Oswald averaging (the mean of the two cells'
   * values at each vertex, the Dirichlet value at x = L) gives the
   * conforming p_tilde in P2(T_h) cap H^1. In time, the physical fluxes of
   * the reconstructions are interpolated linearly between t^{n-1} (the
   * previous step's solution) and t^n (the iterate).
   *
   * *Flux reconstructions* in RT0 (in 1D the continuous piecewise linear
   * functions, given by their face values), constant in time on I_n, for
   * c in {w, h}:
   * - Theta_disc: the finite volume fluxes F_c(U) on the faces;
   * - Theta_lin: F_c^lin(U) - F_c(U), F^lin the fluxes linearised at
   *   U^{k-1}, plus the lifting (cumulated from x = 0) of the linearisation
   *   error of the amounts |K| (l_c^lin(U_K) - l_c(U_K)) / dt;
   * - Theta_alg: the lifting of the algebraic residual r_c,K of the
   *   linearised balance (in 1D the lifting from x = 0, where the flux is
   *   data, is unique: Theta_alg(x_{K+1/2}) = minus the sum of r over the
   *   cells left of the face);
   * - Theta_eq: the lifting of the amounts in the wrong phase, which an
   *   iterate has where it violates the discrete phase equilibrium
   *   C(1 - S_K, b_K) = 0 (the fluxes do not see it): for hydrogen
   *   |min(alpha (1 - S_K), beta b_K)| with alpha = phi gamma_3 P^g_K (kg
   *   per m^3 and unit gas saturation) and beta = phi S_K gamma_2 chi_ref
   *   (kg per m^3 and unit relative molar fraction): the gas that should
   *   dissolve, the dissolved excess that should form gas, or negative
   *   gas; for water phi rho_w (S_K - 1)^+. It vanishes at the discrete
   *   solution, and is part of the linearisation error.
   * Theta_disc + Theta_lin + Theta_alg is locally conservative for the
   * nonlinear amounts of U (interpolated linearly in time): the residual
   * estimators vanish identically and are not computed.
   *
   * *Estimators* on a cell K (Phi_c the physical flux of the reconstructed
   * fields with the cell's saturation; 4-point Gauss quadrature in space,
   * exact integration in time):
   *   eta_F^2   = int_{I_n} || Theta_disc - Phi_c(S, P_tilde^l, P_tilde^g,
   *                                              chi_tilde) ||_K^2 dt,
   *   eta_NC^2  = int_{I_n} || Phi_c(S, p_hat) - Phi_c(S, p_tilde) ||_K^2 dt,
   *   eta_lin^2 = dt (|| Theta_lin ||_K^2 + || Theta_eq ||_K^2),
   *   eta_alg^2 = dt || Theta_alg ||_K^2,
   *   eta_C     = | int_{I_n} (1 - S, b_tilde)_K dt |,
   *               b_tilde = P_tilde^g / P_ref - chi_tilde / chi_ref,
   * and globally, with the weights w_c of the balance rows (a change of
   * one in S, of chi_ref in chi):
   *   eta_disc^2 = sum_K sum_c w_c^2 (eta_F + eta_NC)^2,
   *   eta_lin^2  = sum_K sum_c w_c^2 eta_lin^2,   eta_alg likewise,
   *   eta_C      = sum_K eta_C,K.
   */
  class Estimators
  {
  public:
    /// A reconstructed field: per cell its P2 values at (left vertex, right
    /// vertex, midpoint), broken (p_hat) and after Oswald averaging
    /// (p_tilde).
    struct Field
    {
      std::vector<std::array<double, 3>> broken, conforming;
    };

    explicit Estimators(FiniteVolumeScheme &scheme)
        : scheme(scheme)
        , N(scheme.n_cells())
        , quadrature(n_q_points)
        , fluxes_at_linearization(N + 1)
        , amounts_at_linearization(N)
        , theta_disc(N + 1)
        , theta_lin(N + 1)
        , theta_alg(N + 1)
        , theta_eq(N + 1)
        , F_lin(N + 1)
        , previous(N)
        , current(N)
        , cell_values(N)
        , g(N + 1)
        , cell_flux(N)
        , cell_nonconformity(N)
        , cell_phase_transition(N)
    {
      // P2 shape functions on the reference cell, in FE_Q's numbering
      // (left vertex, right vertex, midpoint).
      const dealii::FE_Q<1> fe(2);
      for (unsigned int q = 0; q < n_q_points; ++q)
        for (unsigned int i = 0; i < 3; ++i)
          {
            shape_value[q][i] = fe.shape_value(i, quadrature.point(q));
            shape_grad[q][i]  = fe.shape_grad(i, quadrature.point(q))[0];
          }
    }

    /// The state at t^{n-1}; call after FiniteVolumeScheme::set_time_step().
    void
    set_previous_state(const dealii::Vector<double> &X_old)
    {
      evaluate_state(X_old, previous);
    }

    /// Fluxes and amounts with their derivatives at U^{k-1}.
    void
    set_linearization_point(const dealii::Vector<double> &X)
    {
      X_lin = X;
      scheme.evaluate_cells(X);
      for (unsigned int sigma = 0; sigma <= N; ++sigma)
        fluxes_at_linearization[sigma] = scheme.face_flux(sigma);
      for (unsigned int K = 0; K < N; ++K)
        amounts_at_linearization[K] = scheme.amounts(K);
    }

    EstimatorValues
    estimate(const dealii::Vector<double> &X)
    {
      const double dt = scheme.current_time_step();
      evaluate_state(X, current);
      for (unsigned int sigma = 0; sigma <= N; ++sigma)
        {
          theta_disc[sigma] = scheme.face_flux(sigma).value;
          F_lin[sigma]      = linearized_flux(sigma, X);
        }

      // Face values of Theta_lin and Theta_alg (lifted from x = 0).
      const TwoPhaseModel      &model          = scheme.physical_model();
      const PhysicalParameters &p              = model.parameters();
      std::array<double, 2>     lifted_amounts = {{0., 0.}},
                            lifted_residual    = {{0., 0.}},
                            lifted_equilibrium = {{0., 0.}};
      theta_lin[0]                             = {{0., 0.}};
      theta_alg[0]                             = {{0., 0.}};
      theta_eq[0]                              = {{0., 0.}};
      for (unsigned int K = 0; K < N; ++K)
        {
          const double                h     = scheme.cell_measure(K);
          const auto                  a     = scheme.amounts(K);
          const std::array<double, 2> l_lin = linearized_amounts(K, X);

          const auto &U                     = scheme.cell(K);
          const auto [gas, undersaturation] = scheme.constraint_arguments(K);
          const double alpha =
            p.porosity * model.gamma_3() * (U.P + U.P_cp.value);
          const double beta =
            p.porosity * U.S * model.gamma_2() * scheme.molar_fraction_scale();
          const std::array<double, 2> wrong_phase = {
            {p.porosity * p.water_density * std::max(0., -gas),
             std::abs(std::min(alpha * gas, beta * undersaturation))}};

          for (unsigned int c = 0; c < 2; ++c)
            {
              lifted_equilibrium[c] += h * wrong_phase[c] / dt;
              theta_eq[K + 1][c] = lifted_equilibrium[c];
              lifted_amounts[c] += h * (l_lin[c] - a.value[c]) / dt;
              const double linearized_balance =
                h * (l_lin[c] - scheme.old_amount(K)[c]) / dt +
                F_lin[K + 1][c] - F_lin[K][c];
              lifted_residual[c] -= linearized_balance;
              theta_lin[K + 1][c] =
                F_lin[K + 1][c] - theta_disc[K + 1][c] + lifted_amounts[c];
              theta_alg[K + 1][c] = lifted_residual[c];
            }
        }

      const std::array<double, 2> w = {
        {scheme.component_scale(0), scheme.component_scale(1)}};
      EstimatorValues values;
      double disc2 = 0., lin2 = 0., alg2 = 0., flux2 = 0., nc2 = 0., eq2 = 0.;
      for (unsigned int K = 0; K < N; ++K)
        {
          const double          h = scheme.cell_measure(K);
          std::array<double, 2> eta_F2{}, eta_NC2{}, eta_lin2{}, eta_eq2{},
            eta_alg2{};
          for (unsigned int q = 0; q < n_q_points; ++q)
            {
              const double t   = quadrature.point(q)[0];
              const double JxW = quadrature.weight(q) * h;
              for (unsigned int c = 0; c < 2; ++c)
                {
                  const auto at = [&](const auto &face_values) {
                    return (1. - t) * face_values[K][c] +
                           t * face_values[K + 1][c];
                  };
                  const double theta = at(theta_disc);
                  eta_F2[c] +=
                    JxW *
                    time_integral_of_square(dt,
                                            theta - previous.Phi_tilde[K][q][c],
                                            theta - current.Phi_tilde[K][q][c]);
                  eta_NC2[c] +=
                    JxW * time_integral_of_square(dt,
                                                  previous.Phi_hat[K][q][c] -
                                                    previous.Phi_tilde[K][q][c],
                                                  current.Phi_hat[K][q][c] -
                                                    current.Phi_tilde[K][q][c]);
                  eta_lin2[c] += JxW * dt * std::pow(at(theta_lin), 2);
                  eta_eq2[c] += JxW * dt * std::pow(at(theta_eq), 2);
                  eta_alg2[c] += JxW * dt * std::pow(at(theta_alg), 2);
                }
            }

          double cell_disc2 = 0., cell_flux2 = 0., cell_nc2 = 0.,
                 cell_lin2 = 0., cell_eq2 = 0., cell_alg2 = 0.;
          for (unsigned int c = 0; c < 2; ++c)
            {
              const double w2 = w[c] * w[c];
              cell_disc2 +=
                w2 * std::pow(std::sqrt(eta_F2[c]) + std::sqrt(eta_NC2[c]), 2);
              cell_flux2 += w2 * eta_F2[c];
              cell_nc2 += w2 * eta_NC2[c];
              cell_lin2 += w2 * (eta_lin2[c] + eta_eq2[c]);
              cell_eq2 += w2 * eta_eq2[c];
              cell_alg2 += w2 * eta_alg2[c];
            }
          disc2 += cell_disc2;
          flux2 += cell_flux2;
          nc2 += cell_nc2;
          lin2 += cell_lin2;
          eq2 += cell_eq2;
          alg2 += cell_alg2;
          cell_flux[K]          = std::sqrt(cell_flux2);
          cell_nonconformity[K] = std::sqrt(cell_nc2);

          // (1 - S(t)) int_K b_tilde(t) is quadratic in t: Simpson's rule.
          const auto product = [&](const double s) {
            const double S = (1. - s) * previous.S[K] + s * current.S[K];
            const double B =
              (1. - s) * previous.b_integral[K] + s * current.b_integral[K];
            return (1. - S) * B;
          };
          cell_phase_transition[K] =
            std::abs(dt / 6. * (product(0.) + 4. * product(0.5) + product(1.)));
          values.phase_transition += cell_phase_transition[K];
        }
      values.disc          = std::sqrt(disc2);
      values.flux          = std::sqrt(flux2);
      values.nonconformity = std::sqrt(nc2);
      values.lin           = std::sqrt(lin2);
      values.equilibrium   = std::sqrt(eq2);
      values.alg           = std::sqrt(alg2);
      return values;
    }

    /// The reconstructions of the last estimate().
    const Field &
    reconstructed_liquid_pressure() const
    {
      return current.fields[0];
    }
    const Field &
    reconstructed_gas_pressure() const
    {
      return current.fields[1];
    }
    const Field &
    reconstructed_molar_fraction() const
    {
      return current.fields[2];
    }

    /// Cell indicators of the last estimate() (summed over the components,
    /// weighted and integrated in time as the global values).
    const std::vector<double> &
    flux_indicators() const
    {
      return cell_flux;
    }
    const std::vector<double> &
    nonconformity_indicators() const
    {
      return cell_nonconformity;
    }
    const std::vector<double> &
    phase_transition_indicators() const
    {
      return cell_phase_transition;
    }

  private:
    static constexpr unsigned int n_q_points = 4;
    using QuadratureValues =
      std::array<std::array<double, 2>, n_q_points>; // [q][component]

    /// What the estimators need of the state at one time: the
    /// reconstructions, the physical fluxes Phi_c of p_tilde and p_hat at
    /// the quadrature points, the saturation and int_K b_tilde per cell.
    struct StateValues
    {
      explicit StateValues(const unsigned int N)
          : Phi_tilde(N)
          , Phi_hat(N)
          , S(N)
          , b_integral(N)
      {
        for (Field &field : fields)
          {
            field.broken.resize(N);
            field.conforming.resize(N);
          }
      }
      std::array<Field, 3>          fields; // P^l, P^g, chi
      std::vector<QuadratureValues> Phi_tilde, Phi_hat;
      std::vector<double>           S, b_integral;
    };

    /// int_0^dt f(s)^2 ds for f affine with f(0) = f0, f(dt) = f1.
    static double
    time_integral_of_square(const double dt, const double f0, const double f1)
    {
      return dt / 3. * (f0 * f0 + f0 * f1 + f1 * f1);
    }

    /// F^lin_sigma(U) = F_sigma(U^{k-1}) + F'_sigma(U^{k-1}) (U - U^{k-1}).
    std::array<double, 2>
    linearized_flux(const unsigned int            sigma,
                    const dealii::Vector<double> &X) const
    {
      const auto           &F     = fluxes_at_linearization[sigma];
      std::array<double, 2> value = F.value;
      for (unsigned int side = 0; side < 2; ++side)
        {
          // the left cell sigma - 1 (entries 0..2), the right cell sigma
          // (3..5)
          if ((side == 0 && sigma == 0) || (side == 1 && sigma == N))
            continue;
          add_linear_change(F.derivative, 3 * side, sigma - 1 + side, X, value);
        }
      return value;
    }

    /// l^lin_K(U) = l_K(U^{k-1}) + l'_K(U^{k-1}) (U_K - U_K^{k-1}).
    std::array<double, 2>
    linearized_amounts(const unsigned int            K,
                       const dealii::Vector<double> &X) const
    {
      const auto           &a     = amounts_at_linearization[K];
      std::array<double, 2> value = a.value;
      add_linear_change(a.derivative, 0, K, X, value);
      return value;
    }

    /// value += D (U_K - U_K^{k-1}): D[c][offset + j] is the derivative of
    /// component c by the unknown j of cell K.
    template <typename Derivatives>
    void
    add_linear_change(const Derivatives            &D,
                      const unsigned int            offset,
                      const unsigned int            K,
                      const dealii::Vector<double> &X,
                      std::array<double, 2>        &value) const
    {
      for (unsigned int j = 0; j < 3; ++j)
        {
          const unsigned int i = scheme.index(K, j);
          for (unsigned int c = 0; c < 2; ++c)
            value[c] += D[c][offset + j] * (X[i] - X_lin[i]);
        }
    }

    /// The reconstructions of the state X and their physical fluxes (leaves
    /// the scheme evaluated at X).
    void
    evaluate_state(const dealii::Vector<double> &X, StateValues &state) const
    {
      const TwoPhaseModel      &model = scheme.physical_model();
      const PhysicalParameters &p     = model.parameters();
      const double              g2 = model.gamma_2(), g3 = model.gamma_3();
      scheme.evaluate_cells(X);
      reconstruct(state.fields);

      for (unsigned int K = 0; K < N; ++K)
        {
          const double h        = scheme.cell_measure(K);
          const auto  &cell     = scheme.cell(K);
          const double S        = cell.S;
          const double lambda_l = cell.k_rl.value / p.liquid_viscosity;
          const double lambda_g = cell.k_rg.value / p.gas_viscosity;
          const double a        = p.porosity * p.diffusion_coefficient * S;
          state.S[K]            = S;

          // Phi_c from (P^l, dP^l, P^g, dP^g, chi, dchi).
          const auto physical_flux = [&](const std::array<double, 6> &f) {
            const double q_l = -p.permeability * lambda_l * f[1];
            const double q_g = -p.permeability * lambda_g * f[3];
            const double J   = -a * g2 * f[5];
            return std::array<double, 2>{
              {p.water_density * q_l - J,
               g2 * f[4] * q_l + g3 * f[2] * q_g + J}};
          };

          double b_integral = 0.;
          for (unsigned int q = 0; q < n_q_points; ++q)
            {
              std::array<double, 6> tilde{}, hat{};
              for (unsigned int f = 0; f < 3; ++f)
                for (unsigned int i = 0; i < 3; ++i)
                  {
                    const Field &field = state.fields[f];
                    tilde[2 * f] += field.conforming[K][i] * shape_value[q][i];
                    tilde[2 * f + 1] +=
                      field.conforming[K][i] * shape_grad[q][i] / h;
                    hat[2 * f] += field.broken[K][i] * shape_value[q][i];
                    hat[2 * f + 1] += field.broken[K][i] * shape_grad[q][i] / h;
                  }
              state.Phi_tilde[K][q] = physical_flux(tilde);
              state.Phi_hat[K][q]   = physical_flux(hat);
              b_integral += quadrature.weight(q) * h *
                            (tilde[2] / scheme.pressure_scale() -
                             tilde[4] / scheme.molar_fraction_scale());
            }
          state.b_integral[K] = b_integral;
        }
    }

    /// The P2 reconstructions and their Oswald averages of P^l, P^g, chi
    /// at the state of the scheme's last evaluate_cells().
    void
    reconstruct(std::array<Field, 3> &fields) const
    {
      const TwoPhaseModel      &model = scheme.physical_model();
      const PhysicalParameters &p     = model.parameters();
      const CellState          &D     = scheme.dirichlet_state();

      for (unsigned int K = 0; K < N; ++K)
        {
          const auto &U  = scheme.cell(K);
          cell_values[K] = {{U.P, U.P + U.P_cp.value, U.chi}};
        }
      const std::array<double, 3> dirichlet = {
        {D.P, D.P + model.capillary_pressure(D.S).value, D.chi}};

      // Gradients at x = 0 for which the reconstructed fluxes equal the
      // data: rho_w q^l - J = 0 and gamma_2 chi q^l + gamma_3 P^g q^g + J
      // = injection, with q^l = lambda_l u, q^g = lambda_g u, u = -K dP.
      std::array<double, 3> left_gradient{};
      {
        const auto  &U        = scheme.cell(0);
        const double lambda_l = U.k_rl.value / p.liquid_viscosity;
        const double lambda_g = U.k_rg.value / p.gas_viscosity;
        const double a        = p.porosity * p.diffusion_coefficient * U.S;
        const double den      = model.gamma_2() * U.chi * lambda_l +
                           model.gamma_3() * cell_values[0][1] * lambda_g +
                           p.water_density * lambda_l;
        const double u = den > 0. ? scheme.current_injection_rate() / den : 0.;
        left_gradient[0] = left_gradient[1] = -u / p.permeability;
        left_gradient[2] =
          a > 0. ? -p.water_density * lambda_l * u / (a * model.gamma_2()) : 0.;
      }

      for (unsigned int f = 0; f < 3; ++f)
        {
          Field &field = fields[f];
          g[0]         = left_gradient[f];
          for (unsigned int sigma = 1; sigma < N; ++sigma)
            g[sigma] =
              (cell_values[sigma][f] - cell_values[sigma - 1][f]) /
              (scheme.cell_center(sigma) - scheme.cell_center(sigma - 1));
          g[N] = (dirichlet[f] - cell_values[N - 1][f]) /
                 (0.5 * scheme.cell_measure(N - 1));

          // p_hat(x) = c0 + gL s + (gR - gL) s^2 / (2h), s = x - x_{K-1/2},
          // with mean value p_K.
          for (unsigned int K = 0; K < N; ++K)
            {
              const double h = scheme.cell_measure(K), gL = g[K], gR = g[K + 1];
              const double c0 =
                cell_values[K][f] - gL * h / 2. - (gR - gL) * h / 6.;
              field.broken[K] = {{c0,
                                  c0 + (gL + gR) * h / 2.,
                                  c0 + gL * h / 2. + (gR - gL) * h / 8.}};
            }
          for (unsigned int K = 0; K < N; ++K)
            {
              const double left =
                K == 0 ? field.broken[0][0] :
                         0.5 * (field.broken[K - 1][1] + field.broken[K][0]);
              const double right =
                K == N - 1 ?
                  dirichlet[f] :
                  0.5 * (field.broken[K][1] + field.broken[K + 1][0]);
              field.conforming[K] = {{left, right, field.broken[K][2]}};
            }
        }
    }

    FiniteVolumeScheme                           &scheme;
    const unsigned int                            N;
    const dealii::QGauss<1>                       quadrature;
    std::array<std::array<double, 3>, n_q_points> shape_value{}, shape_grad{};

    dealii::Vector<double>                    X_lin;
    std::vector<FiniteVolumeScheme::FaceFlux> fluxes_at_linearization;
    std::vector<FiniteVolumeScheme::Amounts>  amounts_at_linearization;
    // Face values of Theta_disc, Theta_lin, Theta_alg and F^lin.
    std::vector<std::array<double, 2>> theta_disc, theta_lin, theta_alg,
      theta_eq, F_lin;

    StateValues previous, current;
    // Work space of reconstruct(): cell values and face gradients.
    mutable std::vector<std::array<double, 3>> cell_values;
    mutable std::vector<double>                g;

    std::vector<double> cell_flux, cell_nonconformity, cell_phase_transition;
  };
} // namespace StepTwoPhase
