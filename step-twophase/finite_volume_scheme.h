#pragma once

// The cell-centred finite volume scheme of [BJ14, BDMV20] in 1D: backward
// Euler in time, two-point fluxes with upwinded mobilities, one
// complementarity row per cell. It evaluates the residual, the face fluxes
// with their derivatives, and assembles the generalised Jacobian into a
// deal.II SparseMatrix. Header-only: the unit tests use it directly.

#include <deal.II/lac/dynamic_sparsity_pattern.h>
#include <deal.II/lac/sparse_matrix.h>
#include <deal.II/lac/sparsity_pattern.h>
#include <deal.II/lac/vector.h>

#include <vi/complementarity.h>
#include <vi/semismooth_newton.h>

#include "twophase_model.h"

#include <array>
#include <limits>
#include <vector>

namespace StepTwoPhase
{
  /// The physical state of one cell (or of the Dirichlet boundary).
  struct CellState
  {
    double S   = 1.; ///< liquid saturation
    double P   = 0.; ///< liquid pressure, Pa
    double chi = 0.; ///< molar fraction of dissolved hydrogen
  };


  /**
   * The discrete system of one time step. Cells K = 0..N-1 from left to
   * right, faces sigma = 0..N (face K is the left face of cell K).
   *
   * **Unknowns.** X holds, per cell, the scaled unknowns
   *   S,   P / P_ref,   chi / chi_ref,
   * with P_ref the pressure of the right boundary and chi_ref = H P_ref /
   * beta^l the molar fraction in equilibrium with gas at P_ref: all three
   * are of order one, whereas P ~ 1e6 Pa and chi ~ 1e-4 in SI units.
   *
   * **Equations.** Per cell, in the rows of its three unknowns:
   * - row of S: the phase-transition constraint C(1 - S, b) = 0 with
   *   b = (H (P + P_cp(S)) - beta^l chi) / (H P_ref), i.e. Henry's law
   *   relative to the solubility at P_ref (a C-function keeps its zero set
   *   when an argument is scaled by a positive constant);
   * - row of P: the water balance, divided by phi rho_w |K|, a change of S
   *   by one in the cell;
   * - row of chi: the hydrogen balance, divided by phi gamma_2 chi_ref |K|,
   *   a change of chi by chi_ref in the saturated cell.
   * So every residual is dimensionless and of order one at the start of a
   * step, and Newton's stopping test compares like with like. Pairing each
   * equation with the unknown it mainly determines puts a nonzero on the
   * diagonal whatever the branch of the C-function, which incomplete
   * factorisations need.
   *
   * A balance row is
   *   |K| (l_c(U_K) - l_c(U_K^{n-1})) + dt (F_c,K+1/2 - F_c,K-1/2) = 0,
   * with the face fluxes F (kg m^-2 s^-1, positive towards +x) of
   * face_flux(). At x = 0 the fluxes are the data (no water, the injection
   * rate averaged over the step for hydrogen); at x = L the flux to the
   * Dirichlet state is a two-point flux over the half cell.
   */
  class FiniteVolumeScheme
  {
  public:
    enum Unknown : unsigned int
    {
      saturation     = 0,
      pressure       = 1,
      molar_fraction = 2
    };
    static constexpr unsigned int n_components = 3;

    /// How the 3 N unknowns are numbered.
    enum class Ordering
    {
      cell_wise, ///< (S, P, chi) of cell 0, of cell 1, ...: block tridiagonal
      field_wise ///< all S, all P, all chi: 3 x 3 blocks, each tridiagonal
    };

    /// Face fluxes of water and hydrogen and their derivatives with respect
    /// to the scaled unknowns (S, P/P_ref, chi/chi_ref) of the left cell
    /// (entries 0..2) and the right cell (3..5).
    struct FaceFlux
    {
      std::array<double, 2>                value      = {{0., 0.}};
      std::array<std::array<double, 6>, 2> derivative = {};
    };

    /// Amounts l_w, l_h of a cell and their derivatives with respect to its
    /// scaled unknowns.
    struct Amounts
    {
      std::array<double, 2>                value      = {{0., 0.}};
      std::array<std::array<double, 3>, 2> derivative = {};
    };

    FiniteVolumeScheme(const TwoPhaseModel       &model,
                       const std::vector<double> &vertices,
                       const CellState           &right_state,
                       const Ordering             ordering)
        : model(model)
        , vertices(vertices)
        , right_state(right_state)
        , ordering(ordering)
        , N(vertices.size() - 1)
        , P_ref(right_state.P)
        , chi_ref(model.equilibrium_molar_fraction(right_state.P))
        , balance_scale{{1. / (model.parameters().porosity *
                               model.parameters().water_density),
                         1. / (model.parameters().porosity * model.gamma_2() *
                               chi_ref)}}
        , cells(N)
        , fluxes(N + 1)
        , right_boundary(cell_data(right_state))
        , old_amounts(N)
    {
    }

    /// A cell's physical state with its constitutive laws.
    struct CellData
    {
      double             S = 1., P = 0., chi = 0.;
      SaturationFunction P_cp, k_rl, k_rg;
    };

    /// The state U with the capillary pressure and relative permeabilities
    /// at its saturation.
    CellData
    cell_data(const CellState &U) const
    {
      CellData d;
      d.S    = U.S;
      d.P    = U.P;
      d.chi  = U.chi;
      d.P_cp = model.capillary_pressure(U.S);
      d.k_rl = model.liquid_relative_permeability(U.S);
      d.k_rg = model.gas_relative_permeability(U.S);
      return d;
    }

    unsigned int
    n_cells() const
    {
      return N;
    }

    unsigned int
    n_unknowns() const
    {
      return n_components * N;
    }

    /// The row/column of unknown c of cell K (and of the equation paired
    /// with it).
    unsigned int
    index(const unsigned int K, const unsigned int c) const
    {
      return ordering == Ordering::cell_wise ? n_components * K + c : c * N + K;
    }

    double
    cell_measure(const unsigned int K) const
    {
      return vertices[K + 1] - vertices[K];
    }

    double
    cell_center(const unsigned int K) const
    {
      return 0.5 * (vertices[K] + vertices[K + 1]);
    }

    const std::vector<double> &
    mesh_vertices() const
    {
      return vertices;
    }

    const TwoPhaseModel &
    physical_model() const
    {
      return model;
    }

    const CellState &
    dirichlet_state() const
    {
      return right_state;
    }

    double
    pressure_scale() const
    {
      return P_ref;
    }

    double
    molar_fraction_scale() const
    {
      return chi_ref;
    }

    /// 1 / (phi rho_w) and 1 / (phi gamma_2 chi_ref): what turns an amount
    /// of water or hydrogen (kg/m^3) into the dimensionless unit of its row.
    double
    component_scale(const unsigned int component) const
    {
      return balance_scale[component];
    }

    CellState
    state(const dealii::Vector<double> &X, const unsigned int K) const
    {
      return {X[index(K, saturation)],
              X[index(K, pressure)] * P_ref,
              X[index(K, molar_fraction)] * chi_ref};
    }

    void
    set_state(const unsigned int      K,
              const CellState        &U,
              dealii::Vector<double> &X) const
    {
      X[index(K, saturation)]     = U.S;
      X[index(K, pressure)]       = U.P / P_ref;
      X[index(K, molar_fraction)] = U.chi / chi_ref;
    }

    /// The sparsity of the Jacobian: full 3 x 3 blocks between neighbours.
    void
    make_sparsity_pattern(dealii::SparsityPattern &pattern) const
    {
      dealii::DynamicSparsityPattern dsp(n_unknowns(), n_unknowns());
      for (unsigned int K = 0; K < N; ++K)
        for (unsigned int L = (K > 0 ? K - 1 : 0); L <= std::min(K + 1, N - 1);
             ++L)
          for (unsigned int r = 0; r < n_components; ++r)
            for (unsigned int c = 0; c < n_components; ++c)
              dsp.add(index(K, r), index(L, c));
      pattern.copy_from(dsp);
    }

    /**
     * Start a time step from the state X_old over dt seconds, with the
     * hydrogen injection rate (kg m^-2 s^-1) averaged over the step.
     */
    void
    set_time_step(const dealii::Vector<double> &X_old,
                  const double                  dt,
                  const double                  injection_rate)
    {
      time_step = dt;
      injection = injection_rate;
      evaluate_cells(X_old);
      for (unsigned int K = 0; K < N; ++K)
        old_amounts[K] = amounts(K).value;
    }

    double
    current_time_step() const
    {
      return time_step;
    }

    double
    current_injection_rate() const
    {
      return injection;
    }

    /**
     * Evaluate the constitutive laws in every cell of X and the fluxes
     * through the faces inside and at x = L (cached: the residual, the
     * Jacobian and the estimators of one iterate share them).
     */
    void
    evaluate_cells(const dealii::Vector<double> &X)
    {
      if (cached_X.size() == X.size() &&
          std::equal(X.begin(), X.end(), cached_X.begin()))
        return;
      cached_X = X;
      for (unsigned int K = 0; K < N; ++K)
        {
          cells[K] = cell_data(state(X, K));
        }
      for (unsigned int sigma = 1; sigma <= N; ++sigma)
        {
          const bool boundary = (sigma == N);
          two_point_flux(cells[sigma - 1],
                         boundary ? right_boundary : cells[sigma],
                         0.5 * cell_measure(sigma - 1),
                         boundary ? 0. : 0.5 * cell_measure(sigma),
                         boundary,
                         fluxes[sigma]);
        }
    }

    /// Cell K at the state of the last evaluate_cells().
    const CellData &
    cell(const unsigned int K) const
    {
      return cells[K];
    }

    /// Amounts l_w, l_h of cell K at the state of the last evaluate_cells().
    Amounts
    amounts(const unsigned int K) const
    {
      const CellData &d = cells[K];
      Amounts         a;
      a.value[0] = model.water_amount(d.S);
      a.derivative[0][0] =
        model.parameters().porosity * model.parameters().water_density;
      const auto l_h     = model.hydrogen_amount(d.S, d.P, d.chi, d.P_cp);
      a.value[1]         = l_h.value;
      a.derivative[1][0] = l_h.d_S;
      a.derivative[1][1] = l_h.d_P * P_ref;
      a.derivative[1][2] = l_h.d_chi * chi_ref;
      return a;
    }

    /// l_c at the start of the step.
    const std::array<double, 2> &
    old_amount(const unsigned int K) const
    {
      return old_amounts[K];
    }

    /**
     * The fluxes through face sigma (0..N) at the state of the last
     * evaluate_cells(): water rho_w q^l - J, hydrogen gamma_2 chi q^l +
     * gamma_3 P^g q^g + J, with
     *   q^l = K_perm k_rl(S_up)/mu_l (P_K - P_L)/d,   (upwind by P)
     *   gamma_3 P^g q^g = K_perm gamma_3 P^g_up k_rg(S_up)/mu_g
     *                     (P^g_K - P^g_L)/d,          (upwind by P^g)
     *   J = gamma_2 phi D S_sigma (chi_K - chi_L)/d   (Fick),
     * chi advected from the liquid's upwind cell, phi D S_sigma the
     * distance-weighted harmonic mean of the two cells' phi D S.
     */
    FaceFlux
    face_flux(const unsigned int sigma) const
    {
      if (sigma > 0)
        return fluxes[sigma];
      // x = 0: no water flux, the injected hydrogen (data of the step).
      FaceFlux flux;
      flux.value = {{0., injection}};
      return flux;
    }

    /**
     * R(X): complementarity, water and hydrogen rows (see the class
     * documentation), and their norms: the largest balance residual and the
     * largest complementarity residual, both dimensionless.
     */
    VI::ResidualNorms
    residual(const dealii::Vector<double>      &X,
             const VI::ComplementarityFunction &C,
             dealii::Vector<double>            &R)
    {
      evaluate_cells(X);
      R = 0.;
      for (unsigned int sigma = 0; sigma <= N; ++sigma)
        {
          const FaceFlux F = face_flux(sigma);
          for (unsigned int c = 0; c < 2; ++c)
            {
              if (sigma > 0)
                R[index(sigma - 1, c + 1)] += time_step * F.value[c] *
                                              balance_scale[c] /
                                              cell_measure(sigma - 1);
              if (sigma < N)
                R[index(sigma, c + 1)] -= time_step * F.value[c] *
                                          balance_scale[c] /
                                          cell_measure(sigma);
            }
        }

      VI::ResidualNorms norms;
      for (unsigned int K = 0; K < N; ++K)
        {
          const Amounts a = amounts(K);
          for (unsigned int c = 0; c < 2; ++c)
            {
              double &r = R[index(K, c + 1)];
              r += (a.value[c] - old_amounts[K][c]) * balance_scale[c];
              norms.equations = std::max(norms.equations, std::abs(r));
            }
          const auto [a_K, b_K]   = constraint_arguments(K);
          const double c_K        = C.value(a_K, b_K);
          R[index(K, saturation)] = c_K;
          norms.complementarity =
            std::max(norms.complementarity, std::abs(c_K));
        }
      // max() drops NaN: report it.
      for (const double r : R)
        if (!std::isfinite(r))
          return {std::numeric_limits<double>::quiet_NaN(),
                  std::numeric_limits<double>::quiet_NaN()};
      return norms;
    }

    /// The arguments (1 - S, b) of the constraint of cell K at the state of
    /// the last evaluate_cells(), b scaled by H P_ref.
    std::pair<double, double>
    constraint_arguments(const unsigned int K) const
    {
      const CellData &d = cells[K];
      return {1. - d.S, (d.P + d.P_cp.value) / P_ref - d.chi / chi_ref};
    }

    /**
     * The generalised Jacobian at X: derivatives of the balance rows, and
     * for the constraint rows the chain rule through a = 1 - S and
     * b = P/P_ref + P_cp(S)/P_ref - chi/chi_ref of an element (dC/da, dC/db)
     * of the C-function's generalised gradient.
     */
    void
    assemble_jacobian(const dealii::Vector<double>      &X,
                      const VI::ComplementarityFunction &C,
                      dealii::SparseMatrix<double>      &J)
    {
      evaluate_cells(X);
      J = 0.;
      std::array<unsigned int, 6> columns;
      std::array<double, 6>       values;
      for (unsigned int sigma = 0; sigma <= N; ++sigma)
        {
          if (sigma == 0)
            continue; // the data at x = 0 do not depend on X
          const FaceFlux     F        = face_flux(sigma);
          const unsigned int K        = sigma - 1;
          const bool         boundary = (sigma == N);
          const unsigned int n_cols   = boundary ? 3 : 6;
          for (unsigned int j = 0; j < 3; ++j)
            {
              columns[j] = index(K, j);
              if (!boundary)
                columns[3 + j] = index(sigma, j);
            }
          for (unsigned int c = 0; c < 2; ++c)
            {
              // outflow of K, inflow of L
              for (unsigned int j = 0; j < n_cols; ++j)
                values[j] = time_step * F.derivative[c][j] * balance_scale[c] /
                            cell_measure(K);
              J.add(index(K, c + 1), n_cols, columns.data(), values.data());
              if (!boundary)
                {
                  for (unsigned int j = 0; j < n_cols; ++j)
                    values[j] = -time_step * F.derivative[c][j] *
                                balance_scale[c] / cell_measure(sigma);
                  J.add(index(sigma, c + 1),
                        n_cols,
                        columns.data(),
                        values.data());
                }
            }
        }

      for (unsigned int K = 0; K < N; ++K)
        {
          const Amounts a = amounts(K);
          for (unsigned int c = 0; c < 2; ++c)
            for (unsigned int j = 0; j < 3; ++j)
              J.add(index(K, c + 1),
                    index(K, j),
                    a.derivative[c][j] * balance_scale[c]);

          const auto [a_K, b_K] = constraint_arguments(K);
          const auto   g        = C.generalized_gradient(a_K, b_K);
          const double dPcp     = cells[K].P_cp.derivative / P_ref;
          J.set(index(K, saturation),
                index(K, saturation),
                -g[0] + g[1] * dPcp);
          J.set(index(K, saturation), index(K, pressure), g[1]);
          J.set(index(K, saturation), index(K, molar_fraction), -g[1]);
        }
    }

  private:
    /**
     * Two-point fluxes between the states K (left, at distance d_K from the
     * face) and L (right, at d_L; the Dirichlet state at distance 0 if
     * `boundary`), derivatives with respect to the physical unknowns
     * converted to the scaled ones at the end.
     */
    void
    two_point_flux(const CellData &K,
                   const CellData &L,
                   const double    d_K,
                   const double    d_L,
                   const bool      boundary,
                   FaceFlux       &flux) const
    {
      const PhysicalParameters &p  = model.parameters();
      const double              d  = d_K + d_L;
      const double              T  = p.permeability / d;
      const double              g2 = model.gamma_2();
      const double              g3 = model.gamma_3();
      // Derivatives with respect to (S_K, P_K, chi_K, S_L, P_L, chi_L).
      std::array<double, 6> dq{}, dA{}, dG{}, dJ{};

      // Liquid Darcy flux q^l, mobility upwinded by the pressure difference.
      const double    dP       = K.P - L.P;
      const bool      up_K     = (dP >= 0.);
      const CellData &ul       = up_K ? K : L;
      const unsigned  s_ul     = up_K ? 0 : 3;
      const double    lambda_l = ul.k_rl.value / p.liquid_viscosity;
      const double    q        = T * lambda_l * dP;
      dq[1]                    = T * lambda_l;
      dq[4]                    = -T * lambda_l;
      dq[s_ul] += T * dP * ul.k_rl.derivative / p.liquid_viscosity;

      // Dissolved hydrogen carried by the liquid: gamma_2 chi_up q^l.
      const double A = g2 * ul.chi * q;
      for (unsigned int j = 0; j < 6; ++j)
        dA[j] = g2 * ul.chi * dq[j];
      dA[s_ul + 2] += g2 * q;

      // Hydrogen gas: gamma_3 P^g k_rg / mu_g upwinded by P^g.
      const double    Pg_K    = K.P + K.P_cp.value;
      const double    Pg_L    = L.P + L.P_cp.value;
      const double    dPg     = Pg_K - Pg_L;
      const bool      upg_K   = (dPg >= 0.);
      const CellData &ug      = upg_K ? K : L;
      const unsigned  s_ug    = upg_K ? 0 : 3;
      const double    Pg_up   = ug.P + ug.P_cp.value;
      const double    rho_mob = g3 * Pg_up * ug.k_rg.value / p.gas_viscosity;
      const double    G       = T * rho_mob * dPg;
      // through dPg
      dG[0] = T * rho_mob * K.P_cp.derivative;
      dG[1] = T * rho_mob;
      dG[3] = -T * rho_mob * L.P_cp.derivative;
      dG[4] = -T * rho_mob;
      // through the upwind density and mobility
      dG[s_ug] +=
        T * dPg * g3 / p.gas_viscosity *
        (ug.P_cp.derivative * ug.k_rg.value + Pg_up * ug.k_rg.derivative);
      dG[s_ug + 1] += T * dPg * g3 * ug.k_rg.value / p.gas_viscosity;

      // Fick: J = gamma_2 (chi_K - chi_L) / (d_K/a_K + d_L/a_L), a = phi D S
      // (at the boundary a_K alone over d_K).
      const double phiD = p.porosity * p.diffusion_coefficient;
      const double a_K  = phiD * K.S;
      double       T_D = 0., dT_D_K = 0., dT_D_L = 0.;
      if (boundary)
        {
          T_D    = a_K / d_K;
          dT_D_K = phiD / d_K;
        }
      else
        {
          const double a_L   = phiD * L.S;
          const double denom = d_K * a_L + d_L * a_K;
          if (denom != 0.)
            {
              T_D    = a_K * a_L / denom;
              dT_D_K = phiD * a_L * a_L * d_K / (denom * denom);
              dT_D_L = phiD * a_K * a_K * d_L / (denom * denom);
            }
        }
      const double dchi = K.chi - L.chi;
      const double J    = g2 * T_D * dchi;
      dJ[0]             = g2 * dchi * dT_D_K;
      dJ[3]             = g2 * dchi * dT_D_L;
      dJ[2]             = g2 * T_D;
      dJ[5]             = -g2 * T_D;

      flux.value                       = {{p.water_density * q - J, A + G + J}};
      const std::array<double, 3> unit = {{1., P_ref, chi_ref}};
      for (unsigned int j = 0; j < 6; ++j)
        {
          const double scale = unit[j % 3];
          const bool   fixed = boundary && j >= 3; // the Dirichlet state
          flux.derivative[0][j] =
            fixed ? 0. : (p.water_density * dq[j] - dJ[j]) * scale;
          flux.derivative[1][j] = fixed ? 0. : (dA[j] + dG[j] + dJ[j]) * scale;
        }
    }

    const TwoPhaseModel         model;
    const std::vector<double>   vertices;
    const CellState             right_state;
    const Ordering              ordering;
    const unsigned int          N;
    const double                P_ref;
    const double                chi_ref;
    const std::array<double, 2> balance_scale;

    double time_step = 0.;
    double injection = 0.;

    std::vector<CellData>              cells;
    std::vector<FaceFlux>              fluxes; ///< of the cached state
    CellData                           right_boundary;
    std::vector<std::array<double, 2>> old_amounts;
    dealii::Vector<double>             cached_X;
  };
} // namespace StepTwoPhase
