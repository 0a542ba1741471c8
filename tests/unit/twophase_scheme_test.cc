// The finite volume scheme of step-twophase: derivatives of the
// constitutive laws and the analytic Jacobian against finite differences,
// discrete conservation, and the properties of the a posteriori estimators
// that the adaptive stopping criteria rely on.
#include <deal.II/lac/sparse_direct.h>
#include <deal.II/lac/sparse_matrix.h>
#include <deal.II/lac/vector.h>

#include <gtest/gtest.h>

#include "../../step-twophase/finite_volume_scheme.h"
#include "../../step-twophase/twophase_estimators.h"

#include <algorithm>
#include <cmath>
#include <vector>

using namespace StepTwoPhase;
using dealii::SparseMatrix;
using dealii::SparsityPattern;
using dealii::Vector;

namespace
{
  const PhysicalParameters benchmark; // the Couplex-Gas data

  std::vector<double>
  uniform_vertices(const unsigned int n, const double length)
  {
    std::vector<double> v(n + 1);
    for (unsigned int i = 0; i <= n; ++i)
      v[i] = length * i / n;
    return v;
  }

  /// Saturated with water, no dissolved hydrogen, 1 MPa: the benchmark's
  /// initial state and its state at x = L.
  const CellState saturated{1., 1e6, 0.};

  /// The scheme of the benchmark's data on n equal cells of [0, length].
  FiniteVolumeScheme
  scheme_on(const TwoPhaseModel               &model,
            const unsigned int                 n,
            const double                       length,
            const FiniteVolumeScheme::Ordering ordering)
  {
    return FiniteVolumeScheme(model,
                              uniform_vertices(n, length),
                              saturated,
                              ordering);
  }

  /// A state with gas in the left half (in equilibrium up to a perturbation
  /// that keeps every pair away from the kink of min), pressures that rise
  /// and fall (upwinding in both directions) and dissolved hydrogen.
  Vector<double>
  mixed_state(const FiniteVolumeScheme &scheme)
  {
    const TwoPhaseModel model(benchmark);
    Vector<double>      X(scheme.n_unknowns());
    const unsigned int  N = scheme.n_cells();
    for (unsigned int K = 0; K < N; ++K)
      {
        CellState U;
        U.S             = K < N / 2 ? 0.985 + 0.002 * K : 1.;
        U.P             = 1.1e6 + 4e4 * std::sin(1.3 * K + 0.4);
        const double Pg = U.P + model.capillary_pressure(U.S).value;
        U.chi =
          model.equilibrium_molar_fraction(Pg) * (K < N / 2 ? 1.003 : 0.6);
        scheme.set_state(K, U, X);
      }
    return X;
  }

  void
  set_up(FiniteVolumeScheme &scheme, SparsityPattern &pattern)
  {
    scheme.make_sparsity_pattern(pattern);
  }
} // namespace


TEST(TwoPhaseModel, DerivativesOfTheConstitutiveLaws)
{
  const TwoPhaseModel model(benchmark);
  // Inside (0.4, 1), in both regularised intervals and beyond [S_lr, 1].
  for (const double S :
       {0.35, 0.400001, 0.45, 0.7, 0.93, 0.99, 0.9999, 0.999997, 1.000002, 1.1})
    {
      const double h = 1e-7 * std::max(1e-3, 1. - S > 0 ? 1. - S : 1.);
      for (const auto law : {&TwoPhaseModel::capillary_pressure,
                             &TwoPhaseModel::liquid_relative_permeability,
                             &TwoPhaseModel::gas_relative_permeability})
        {
          const SaturationFunction f = (model.*law)(S);
          const double             fd =
            ((model.*law)(S + h).value - (model.*law)(S - h).value) / (2 * h);
          EXPECT_NEAR(f.derivative, fd, 1e-5 * std::max(1., std::abs(fd)))
            << "at S = " << S;
          EXPECT_TRUE(std::isfinite(f.value));
        }
    }
  // The values the benchmark relies on: no capillary pressure and no gas
  // mobility at full saturation, and P_cp decreasing.
  EXPECT_EQ(model.capillary_pressure(1.).value, 0.);
  EXPECT_EQ(model.gas_relative_permeability(1.).value, 0.);
  EXPECT_EQ(model.liquid_relative_permeability(1.).value, 1.);
  EXPECT_LT(model.capillary_pressure(0.95).derivative, 0.);
}


TEST(TwoPhaseModel, HenryAndIdealGas)
{
  const TwoPhaseModel model(benchmark);
  // beta^l = rho_w / M_w = 1e5 mol/m^3; gamma_2 = M_h beta^l = 200 kg/m^3;
  // gamma_3 = M_h / (R T).
  EXPECT_DOUBLE_EQ(model.beta_l(), 1e5);
  EXPECT_DOUBLE_EQ(model.gamma_2(), 200.);
  EXPECT_DOUBLE_EQ(model.gamma_3(), 2e-3 / (8.314 * 303.));
  // At equilibrium with 1e6 Pa of gas the liquid holds H P = 7.65 mol/m^3,
  // i.e. 0.0153 kg/m^3 of hydrogen.
  const double chi = model.equilibrium_molar_fraction(1e6);
  EXPECT_DOUBLE_EQ(chi * model.beta_l(), 7.65);
  EXPECT_NEAR(chi * model.gamma_2(), 0.0153, 1e-15);
}


// Every column of the analytic Jacobian against centred differences of the
// residual, for both orderings and both C-functions, in the interior and at
// both boundaries.
TEST(FiniteVolumeScheme, JacobianMatchesFiniteDifferences)
{
  const TwoPhaseModel model(benchmark);
  for (const auto ordering : {FiniteVolumeScheme::Ordering::cell_wise,
                              FiniteVolumeScheme::Ordering::field_wise})
    for (const std::string c_function : {"min", "fischer-burmeister"})
      {
        const auto C = VI::ComplementarityFunction::from_name(c_function);
        FiniteVolumeScheme scheme = scheme_on(model, 8, 2., ordering);
        SparsityPattern    pattern;
        set_up(scheme, pattern);
        SparseMatrix<double> J(pattern);

        const Vector<double> X = mixed_state(scheme);
        Vector<double>       X_old(X);
        for (unsigned int K = 0; K < scheme.n_cells(); ++K)
          X_old[scheme.index(K, 1)] *= 0.999;
        scheme.set_time_step(X_old, 1e3 * seconds_per_year, 2e-13);
        scheme.assemble_jacobian(X, C, J);

        const unsigned int n = scheme.n_unknowns();
        Vector<double>     Xp(X), Xm(X), R0(n), Rp(n), Rm(n);
        scheme.residual(X, C, R0);
        for (unsigned int j = 0; j < n; ++j)
          {
            // At S = 1 the laws have a kink (their regularised pieces end):
            // the Jacobian holds the derivative from the left, compared
            // with the second-order backward difference (3 f(x) - 4 f(x-h)
            // + f(x-2h)) / 2h, exact for the quadratic products of the
            // linear pieces there. Elsewhere centred differences.
            const bool   at_kink = (X[j] == 1.);
            const double h       = 1e-7;
            Xp                   = X;
            Xm                   = X;
            Xp[j] += at_kink ? -2. * h : h;
            Xm[j] -= h;
            scheme.residual(Xp, C, Rp);
            scheme.residual(Xm, C, Rm);
            for (unsigned int i = 0; i < n; ++i)
              {
                const double fd =
                  at_kink ? (3. * R0[i] - 4. * Rm[i] + Rp[i]) / (2. * h) :
                            (Rp[i] - Rm[i]) / (2. * h);
                const double analytic = pattern.exists(i, j) ? J.el(i, j) : 0.;
                EXPECT_NEAR(analytic, fd, 1e-5 * std::max(1., std::abs(fd)))
                  << c_function
                  << (ordering == FiniteVolumeScheme::Ordering::cell_wise ?
                        " cell-wise" :
                        " field-wise")
                  << ", row " << i << ", column " << j;
              }
          }
      }
}


// Summing the balance rows telescopes the fluxes: what the cells gained is
// what entered at x = 0 minus what left at x = L.
TEST(FiniteVolumeScheme, ConservesBothComponents)
{
  const TwoPhaseModel model(benchmark);
  FiniteVolumeScheme  scheme =
    scheme_on(model, 10, 3., FiniteVolumeScheme::Ordering::field_wise);
  const auto           C = VI::ComplementarityFunction::from_name("min");
  const Vector<double> X = mixed_state(scheme);
  Vector<double>       X_old(X);
  for (unsigned int K = 0; K < scheme.n_cells(); ++K)
    X_old[scheme.index(K, 2)] *= 0.99;
  const double dt = 2e3 * seconds_per_year, injection = 1.7e-13;
  scheme.set_time_step(X_old, dt, injection);
  Vector<double> R(scheme.n_unknowns());
  scheme.residual(X, C, R);

  for (unsigned int c = 0; c < 2; ++c)
    {
      double rows = 0., gained = 0.;
      for (unsigned int K = 0; K < scheme.n_cells(); ++K)
        {
          const double h = scheme.cell_measure(K);
          rows += h * R[scheme.index(K, c + 1)] / scheme.component_scale(c);
          gained += h * (scheme.amounts(K).value[c] - scheme.old_amount(K)[c]);
        }
      const double inflow  = scheme.face_flux(0).value[c];
      const double outflow = scheme.face_flux(scheme.n_cells()).value[c];
      const double scale   = std::max({std::abs(gained),
                                       dt * std::abs(inflow),
                                       dt * std::abs(outflow),
                                       std::abs(rows)});
      EXPECT_NEAR(rows, gained + dt * (outflow - inflow), 1e-12 * scale)
        << "component " << c;
      EXPECT_GT(scale, 0.);
    }
  // The injected hydrogen enters at x = 0, no water.
  EXPECT_EQ(scheme.face_flux(0).value[0], 0.);
  EXPECT_EQ(scheme.face_flux(0).value[1], injection);
}


// The benchmark's initial state (saturated, no hydrogen) is a steady state
// without injection: zero residual, the min pair on its branch 1 - S = 0.
TEST(FiniteVolumeScheme, InitialStateIsSteady)
{
  const TwoPhaseModel model(benchmark);
  FiniteVolumeScheme  scheme =
    scheme_on(model, 5, 200., FiniteVolumeScheme::Ordering::cell_wise);
  Vector<double> X(scheme.n_unknowns());
  for (unsigned int K = 0; K < 5; ++K)
    scheme.set_state(K, saturated, X);
  scheme.set_time_step(X, 5e3 * seconds_per_year, 0.);
  Vector<double>          R(X.size());
  const VI::ResidualNorms norms =
    scheme.residual(X, VI::ComplementarityFunction::from_name("min"), R);
  EXPECT_EQ(norms.equations, 0.);
  EXPECT_EQ(norms.complementarity, 0.);
}


namespace
{
  /// Newton-min with LU on one time step of a small benchmark from the state
  /// X0, returning the iterates.
  struct SmallBenchmark
  {
    SmallBenchmark()
        : model(benchmark)
        , scheme(
            scheme_on(model, 40, 20., FiniteVolumeScheme::Ordering::cell_wise))
        , C(VI::ComplementarityFunction::from_name("min"))
    {
      scheme.make_sparsity_pattern(pattern);
      J.reinit(pattern);
    }

    /// Solve one step of dt years from X (returned converged), recording
    /// the linearisation point of the last Newton step in X_lin.
    void
    newton(Vector<double> &X, Vector<double> &X_lin)
    {
      Vector<double> R(X.size()), dX(X.size());
      for (unsigned int k = 0; k < 50; ++k)
        {
          const VI::ResidualNorms norms = scheme.residual(X, C, R);
          // (rounding leaves balance residuals of about 3e-11 here)
          if (norms.equations < 1e-9 && norms.complementarity < 1e-9)
            return;
          X_lin = X;
          scheme.assemble_jacobian(X, C, J);
          dealii::SparseDirectUMFPACK lu;
          lu.initialize(J);
          R *= -1.;
          lu.vmult(dX, R);
          X += dX;
        }
      FAIL() << "Newton-min did not converge";
    }

    const TwoPhaseModel               model;
    FiniteVolumeScheme                scheme;
    const VI::ComplementarityFunction C;
    SparsityPattern                   pattern;
    SparseMatrix<double>              J;
  };
} // namespace


// At the discrete solution the linearisation and algebraic estimators vanish
// (up to rounding) while the discretisation estimator does not; an iterate
// with an algebraic residual gets exactly the lifted residual as eta_alg.
TEST(Estimators, SeparateTheErrorComponents)
{
  SmallBenchmark     b;
  const unsigned int N = b.scheme.n_cells();
  // Dissolved hydrogen near x = 0, close to saturation, so that gas appears
  // during the step.
  Vector<double> X_old(b.scheme.n_unknowns());
  for (unsigned int K = 0; K < N; ++K)
    b.scheme.set_state(K,
                       CellState{1.,
                                 1e6,
                                 b.model.equilibrium_molar_fraction(1e6) *
                                   std::max(0., 0.995 - 0.05 * K)},
                       X_old);
  const double dt = 2e3 * seconds_per_year;
  b.scheme.set_time_step(X_old, dt, 1e-12);

  Estimators estimators(b.scheme);
  estimators.set_previous_state(X_old);
  Vector<double> X(X_old), X_lin(X_old);
  b.newton(X, X_lin);
  ASSERT_LT(X[b.scheme.index(0, 0)], 1.) << "gas should have appeared";

  estimators.set_linearization_point(X_lin);
  const EstimatorValues converged = estimators.estimate(X);
  EXPECT_GT(converged.disc, 0.);
  EXPECT_LT(converged.lin, 1e-8 * converged.disc);
  EXPECT_LT(converged.alg, 1e-8 * converged.disc);
  EXPECT_LT(converged.equilibrium, 1e-8 * converged.disc);
  EXPECT_GT(converged.phase_transition, 0.);

  // The first Newton step from X_old, its linear system solved only to 90%:
  // eta_alg is the L2 norm (in space and time, weighted) of the lifted
  // residual of the linearised balance equations.
  estimators.set_linearization_point(X_old);
  b.scheme.assemble_jacobian(X_old, b.C, b.J);
  Vector<double> R(X.size()), dX(X.size()), r(X.size());
  b.scheme.residual(X_old, b.C, R);
  R *= -1.;
  dealii::SparseDirectUMFPACK lu;
  lu.initialize(b.J);
  lu.vmult(dX, R);
  dX *= 0.9;
  b.J.vmult(r, dX);
  r -= R; // the linearised residual R(X_old) + A dX
  Vector<double> X_partial(X_old);
  X_partial += dX;
  const EstimatorValues partial  = estimators.estimate(X_partial);
  double                expected = 0.;
  for (unsigned int c = 0; c < 2; ++c)
    {
      // Theta_alg(x_{K+1/2}) = - sum_{K' <= K} |K'| r_K' / (w_c dt), and
      // r / (w_c dt) is the residual in kg m^-2 s^-1; piecewise linear, so
      // its squared L2 norm is h/3 (left^2 + left right + right^2).
      double left = 0., lifted = 0., norm2 = 0.;
      for (unsigned int K = 0; K < N; ++K)
        {
          const double h = b.scheme.cell_measure(K);
          lifted -= h * r[b.scheme.index(K, c + 1)] /
                    (b.scheme.component_scale(c) * dt);
          norm2 += h / 3. * (left * left + left * lifted + lifted * lifted);
          left = lifted;
        }
      expected += std::pow(b.scheme.component_scale(c), 2) * dt * norm2;
    }
  EXPECT_NEAR(partial.alg, std::sqrt(expected), 1e-8 * std::sqrt(expected));
  EXPECT_GT(partial.alg, 1e3 * converged.alg);
}


// The P2 reconstruction keeps the cell means, Oswald averaging makes it
// continuous with the Dirichlet value at x = L.
TEST(Estimators, ReconstructionsKeepMeansAndAreConforming)
{
  SmallBenchmark       b;
  const Vector<double> X = mixed_state(b.scheme);
  b.scheme.set_time_step(X, 1e3 * seconds_per_year, 1e-13);
  Estimators estimators(b.scheme);
  estimators.set_previous_state(X);
  estimators.set_linearization_point(X);
  estimators.estimate(X);

  const unsigned int N = b.scheme.n_cells();
  const auto        &P = estimators.reconstructed_liquid_pressure();
  for (unsigned int K = 0; K < N; ++K)
    {
      // Simpson's rule is exact for the quadratic: (left + right + 4 mid)/6.
      const double mean =
        (P.broken[K][0] + P.broken[K][1] + 4. * P.broken[K][2]) / 6.;
      EXPECT_NEAR(mean, b.scheme.state(X, K).P, 1e-9 * 1e6);
      if (K + 1 < N)
        {
          EXPECT_EQ(P.conforming[K][1], P.conforming[K + 1][0]);
        }
    }
  EXPECT_EQ(P.conforming[N - 1][1], 1e6);
}
