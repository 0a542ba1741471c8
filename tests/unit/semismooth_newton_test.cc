// SemismoothNewton on a small linear complementarity problem, independent of
// any mesh: the discrete 1D obstacle problem
//   K u - lambda = f,  u - psi >= 0,  lambda >= 0,  (u - psi) lambda = 0.
#include <deal.II/lac/full_matrix.h>
#include <deal.II/lac/vector.h>

#include <vi/complementarity.h>
#include <vi/errors.h>
#include <vi/parameters.h>
#include <vi/semismooth_newton.h>

#include <gtest/gtest.h>

#include "test_helpers.h"

#include <array>
#include <cmath>
#include <iostream>
#include <limits>
#include <memory>
#include <string>
#include <vector>

using dealii::FullMatrix;
using dealii::Vector;
using VI::ComplementarityFunction;

namespace
{
  /// X = (u, lambda), n interior nodes of (0, 1), f = -8, obstacle psi = -0.5.
  class ObstacleProblem
  {
  public:
    explicit ObstacleProblem(const unsigned int             n,
                             const ComplementarityFunction &C)
        : n(n)
        , C(C)
        , K(n, n)
        , f(n)
        , psi(n)
        , jacobian(2 * n, 2 * n)
    {
      const double h = 1. / (n + 1);
      for (unsigned int i = 0; i < n; ++i)
        {
          K(i, i) = 2. / h;
          if (i > 0)
            K(i, i - 1) = -1. / h;
          if (i + 1 < n)
            K(i, i + 1) = -1. / h;
          f(i)   = -8. * h;
          psi(i) = -0.5;
        }
    }

    VI::ResidualNorms
    residual(const Vector<double> &X, Vector<double> &R) const
    {
      VI::ResidualNorms norms;
      double            equations = 0, load = 0;
      for (unsigned int i = 0; i < n; ++i)
        {
          double Ku = 0;
          for (unsigned int j = 0; j < n; ++j)
            Ku += K(i, j) * X(j);
          R(i)           = Ku - X(n + i) - f(i);
          const double a = X(i) - psi(i), b = X(n + i);
          R(n + i) = interior ?
                       U * (a / U * b / B - targets[i]) / (a / U + b / B) :
                     mu > 0 ? U * C.smoothed_value(a / U, b / B, mu) :
                              C.value(a, b);
          equations += R(i) * R(i);
          load += f(i) * f(i);
          norms.complementarity =
            std::max(norms.complementarity, std::abs(C.value(a, b)));
          norms.smoothed_complementarity =
            std::max(norms.smoothed_complementarity, std::abs(R(n + i)) / U);
        }
      norms.equations = std::sqrt(equations / load);
      return norms;
    }

    void
    setup_jacobian(const Vector<double> &X)
    {
      jacobian = 0;
      for (unsigned int i = 0; i < n; ++i)
        {
          for (unsigned int j = 0; j < n; ++j)
            jacobian(i, j) = K(i, j);
          jacobian(i, n + i) = -1.;
          const double a = X(i) - psi(i), b = X(n + i);
          const double x = a / U, y = b / B;
          const auto   g     = interior ? std::array<double, 2>{{y, x}} :
                               mu > 0   ? C.smoothed_gradient(x, y, mu) :
                                          C.generalized_gradient(a, b);
          const double scale = interior ? 1. / (x + y) : 1.;
          jacobian(n + i, i) = scale * g[0];
          jacobian(n + i, n + i) =
            scale * (mu > 0 || interior ? g[1] * U / B : g[1]);
        }
      inverse = jacobian;
      inverse.gauss_jordan();
    }

    unsigned int
    solve(const Vector<double> &rhs, Vector<double> &dX) const
    {
      inverse.vmult(dX, rhs);
      return 0;
    }

    VI::SemismoothNewton<Vector<double>>
    make_newton(
      const typename VI::SemismoothNewton<Vector<double>>::AdditionalData &data)
    {
      VI::SemismoothNewton<Vector<double>> newton(data);
      newton.residual = [this](const auto &X, auto &R) {
        return residual(X, R);
      };
      newton.setup_jacobian      = [this](const auto &X) { setup_jacobian(X); };
      newton.solve_with_jacobian = [this](const auto &rhs, auto &dX) {
        return solve(rhs, dX);
      };
      return newton;
    }

    /// The smoothing of SemismoothNewton::set_smoothing, with the scales
    /// of the gap and the multiplier frozen when it starts.
    void
    set_smoothing(const Vector<double> &X, const double new_mu)
    {
      if (mu == 0 && new_mu > 0)
        {
          U = B = 1e-300;
          for (unsigned int i = 0; i < n; ++i)
            {
              U = std::max(U, std::abs(X(i) - psi(i)));
              B = std::max(B, std::abs(X(n + i)));
            }
        }
      mu = new_mu;
    }

    /// The interior-point rows U (x y - t_i) / (x + y) of
    /// SemismoothNewton::InteriorPointRows, with the scales U, B of
    /// set_smoothing().
    void
    attach_interior_point(VI::SemismoothNewton<Vector<double>> &newton)
    {
      auto &rows = newton.interior_point;
      rows.enter = [this](Vector<double> &X, const double mu2) {
        set_smoothing(X, 1.); // (only the scales)
        mu       = 0;
        interior = true;
        targets.assign(n, 0.);
        for (unsigned int i = 0; i < n; ++i)
          {
            double x = (X(i) - psi(i)) / U, y = X(n + i) / B;
            if (x >= y)
              y = mu2 / (x = std::max(x, std::sqrt(mu2)));
            else
              x = mu2 / (y = std::max(y, std::sqrt(mu2)));
            X(i)     = psi(i) + x * U;
            X(n + i) = y * B;
          }
      };
      rows.set_targets = [this](const Vector<double> *dX, const double t) {
        for (unsigned int i = 0; i < n; ++i)
          targets[i] = t - (dX ? (*dX)(i) / U * (*dX)(n + i) / B : 0.);
      };
      rows.centre = [this](const Vector<double> &X,
                           const Vector<double> &dX,
                           const double          s,
                           const double          target) {
        for (unsigned int i = 0; i < n; ++i)
          {
            const double v = ((X(i) - psi(i)) / U + s * dX(i) / U) *
                             (X(n + i) / B + s * dX(n + i) / B);
            if (v < 0.1 * target)
              targets[i] += 0.1 * target - v;
            else if (v > 10. * target)
              targets[i] += std::max(10. * target - v, -10. * target);
          }
      };
      rows.solve_rows = [this](const Vector<double> &X, Vector<double> &dX) {
        for (unsigned int i = 0; i < n; ++i)
          {
            const double x = (X(i) - psi(i)) / U, y = X(n + i) / B,
                         rhs = targets[i] - x * y;
            if (x >= y)
              dX(n + i) = B * (rhs - y * dX(i) / U) / x;
            else
              dX(i) = U * (rhs - x * dX(n + i) / B) / y;
          }
      };
      rows.step_to_boundary =
        [this](const Vector<double> &X, const Vector<double> &dX, double s) {
          double t = std::numeric_limits<double>::infinity(), sum = 0;
          for (unsigned int i = 0; i < n; ++i)
            {
              const double x = (X(i) - psi(i)) / U, y = X(n + i) / B,
                           dx = dX(i) / U, dy = dX(n + i) / B;
              if (dx < 0)
                t = std::min(t, -x / dx);
              if (dy < 0)
                t = std::min(t, -y / dy);
              sum += (x + s * dx) * (y + s * dy);
            }
          return std::array<double, 2>{{t, sum / n}};
        };
      rows.leave = [this]() {
        interior = false;
        U = B = 1;
      };
    }

    /// The string on the obstacle (u = psi, lambda = 0): every node is a
    /// tie, hence active, and the active set stalls (the tests below).
    Vector<double>
    on_the_obstacle() const
    {
      Vector<double> X(2 * n);
      for (unsigned int i = 0; i < n; ++i)
        X(i) = psi(i);
      return X;
    }

    /// The active_set callback for the stalled string: the active nodes at
    /// X, and every step counted as switching, so that the continuation
    /// starts by the residuals alone.
    VI::ActiveSetChange
    stalling_active_set(const Vector<double> &X) const
    {
      VI::ActiveSetChange change;
      for (unsigned int i = 0; i < n; ++i)
        change.active += X(i) - psi(i) <= X(n + i);
      change.switched = 1;
      return change;
    }

    /// The active set of Newton-min's linearisation at X (the nodes with
    /// X - psi <= lambda), compared with the previous one unless `first`:
    /// the SemismoothNewton::active_set callback.
    VI::ActiveSetChange
    active_set(const Vector<double> &X, const bool first)
    {
      VI::ActiveSetChange change;
      std::vector<bool>   now(n);
      for (unsigned int i = 0; i < n; ++i)
        {
          now[i] = X(i) - psi(i) <= X(n + i);
          change.active += now[i];
          change.switched += !first && now[i] != active[i];
        }
      active = now;
      return change;
    }

    const unsigned int      n;
    ComplementarityFunction C;
    double                  mu = 0, U = 1, B = 1;
    bool                    interior = false; ///< interior-point rows
    std::vector<double>     targets;          ///< their t_i
    FullMatrix<double>      K;
    Vector<double>          f, psi;
    FullMatrix<double>      jacobian, inverse;
    std::vector<bool>       active; ///< of the last active_set() call
  };


  /// Check the discrete KKT conditions to round-off.
  void
  expect_solution(const ObstacleProblem &problem, const Vector<double> &X)
  {
    const unsigned int n         = problem.n;
    unsigned int       n_contact = 0;
    for (unsigned int i = 0; i < n; ++i)
      {
        const double gap = X(i) - problem.psi(i), lambda = X(n + i);
        EXPECT_GE(gap, -1e-12);
        EXPECT_GE(lambda, -1e-12);
        EXPECT_NEAR(gap * lambda, 0., 1e-14);
        if (gap < 1e-12)
          ++n_contact;
      }
    Vector<double>          R(2 * n);
    ComplementarityFunction min(ComplementarityFunction::Type::min);
    EXPECT_LT(problem.residual(X, R).equations, 1e-12);
    // The force pushes the string onto the obstacle in the middle only.
    EXPECT_GT(n_contact, 0u);
    EXPECT_LT(n_contact, n);
  }


  /// Newton with `data` from X = 0 must fail with a SolverFailure that
  /// says `reason`.
  void
  expect_failure(
    ObstacleProblem &problem,
    const typename VI::SemismoothNewton<Vector<double>>::AdditionalData &data,
    const std::string                                                   &reason)
  {
    auto           newton = problem.make_newton(data);
    Vector<double> X(2 * problem.n);
    VITest::expect_error_saying<VI::SolverFailure>(reason,
                                                   [&] { newton.solve(X); });
  }
} // namespace


TEST(SemismoothNewton, NewtonMinSolvesTheObstacleProblemInFinitelyManySteps)
{
  ObstacleProblem problem(40, ComplementarityFunction());
  typename VI::SemismoothNewton<Vector<double>>::AdditionalData data;
  data.tolerance        = 1e-13;
  auto           newton = problem.make_newton(data);
  Vector<double> X(80);
  const auto     report = newton.solve(X);
  expect_solution(problem, X);
  // Newton-min is the primal-dual active set method: it stops with the
  // exact discrete solution once the contact set is found.
  EXPECT_LE(report.iterations, 10u);
  EXPECT_EQ(report.final_residual.complementarity, 0.);
}


TEST(SemismoothNewton, FischerBurmeisterWithLineSearchReachesTheSameSolution)
{
  ObstacleProblem problem_min(40, ComplementarityFunction());
  ObstacleProblem problem_fb(
    40,
    ComplementarityFunction(ComplementarityFunction::Type::fischer_burmeister));
  typename VI::SemismoothNewton<Vector<double>>::AdditionalData data;
  data.tolerance = 1e-13;
  Vector<double> X_min(80);
  problem_min.make_newton(data).solve(X_min);
  // With the Armijo test on every step and with the watchdog (8 full steps
  // before the test): the watchdog changes the path, not the solution, and
  // takes no more steps here.
  data.line_search = true;
  unsigned int iterations[2];
  for (const unsigned int watchdog_steps : {0u, 8u})
    {
      data.watchdog_steps = watchdog_steps;
      Vector<double> X_fb(80);
      const auto     report = problem_fb.make_newton(data).solve(X_fb);
      expect_solution(problem_fb, X_fb);
      for (unsigned int i = 0; i < 80; ++i)
        EXPECT_NEAR(X_fb(i), X_min(i), 1e-10);
      EXPECT_LE(report.iterations, 30u);
      iterations[watchdog_steps > 0] = report.iterations;
    }
  EXPECT_LE(iterations[1], iterations[0]);
}


TEST(SemismoothNewton, IterationLimitIsAFailureWithAReason)
{
  ObstacleProblem problem(40, ComplementarityFunction());
  typename VI::SemismoothNewton<Vector<double>>::AdditionalData data;
  data.max_iterations = 1;
  data.tolerance      = 1e-13;
  // One iteration cannot find the contact set.
  expect_failure(problem, data, "no convergence in 1");
}


TEST(SemismoothNewton, StagnationAtTheAccuracyOfTheSolvesIsAFailureAtOnce)
{
  // Newton-min finds the contact set of the obstacle problem in a few
  // steps; a residual that keeps a floor of 1e-9 after that (as the
  // round-off of an ill-conditioned linear solve does) is reported three
  // steps later, not at the iteration limit. Without the floor the same
  // settings converge.
  ObstacleProblem problem(40, ComplementarityFunction());
  typename VI::SemismoothNewton<Vector<double>>::AdditionalData data;
  data.tolerance     = 1e-13;
  data.continuation  = false;
  unsigned int plain = 0; // the steps without the floor
  for (const double floor : {0., 1e-9})
    {
      auto newton     = problem.make_newton(data);
      newton.residual = [&](const Vector<double> &X, Vector<double> &R) {
        VI::ResidualNorms norms = problem.residual(X, R);
        norms.complementarity   = std::max(norms.complementarity, floor);
        return norms;
      };
      newton.active_set = [&](const Vector<double> &X, const bool first) {
        return problem.active_set(X, first);
      };
      Vector<double> X(2 * problem.n);
      if (floor == 0)
        {
          const auto report = newton.solve(X);
          expect_solution(problem, X);
          plain = report.iterations;
          continue;
        }
      unsigned int steps = 0;
      newton.monitor     = [&](const VI::NewtonStep &) { ++steps; };
      VITest::expect_error_saying<VI::SolverFailure>(
        "has not changed in the last 3 steps", [&] { newton.solve(X); });
      EXPECT_LE(steps, plain + 3);
      EXPECT_GE(steps, plain + 1);
    }
}


TEST(SemismoothNewton, NotANumberIsAFailureWithAReason)
{
  ObstacleProblem problem(10, ComplementarityFunction());
  problem.f(3) = std::nan("");
  // NaN in the data must stop Newton.
  expect_failure(problem, /*default settings*/ {}, "not a number");
}


TEST(SemismoothNewton, ProblemStoppingCriterionEndsTheIteration)
{
  // The adaptive strategy stops Newton by a criterion of the problem's own;
  // here: after the second step, whatever the residual.
  ObstacleProblem problem(40, ComplementarityFunction());
  typename VI::SemismoothNewton<Vector<double>>::AdditionalData data;
  data.tolerance            = 1e-13;
  auto newton               = problem.make_newton(data);
  newton.stopping_criterion = [](const Vector<double> &,
                                 const VI::NewtonStep &step) {
    return step.iteration == 2;
  };
  Vector<double> X(80);
  const auto     report = newton.solve(X);
  EXPECT_EQ(report.iterations, 2u);
  EXPECT_GT(report.final_residual.complementarity, 0.);
}


TEST(SemismoothNewton, ActiveSetsOfTheLinearisationsAreReported)
{
  // Newton-min is the primal-dual active set method: the active set of its
  // last linearisation is the contact set of the solution, and each step
  // reports its set and how many nodes switched since the previous one.
  ObstacleProblem problem(40, ComplementarityFunction());
  typename VI::SemismoothNewton<Vector<double>>::AdditionalData data;
  data.tolerance      = 1e-13;
  auto         newton = problem.make_newton(data);
  unsigned int calls  = 0;
  newton.active_set   = [&](const Vector<double> &X, const bool first) {
    EXPECT_EQ(first, calls++ == 0);
    return problem.active_set(X, first);
  };
  Vector<double> X(80);
  const auto     report = newton.solve(X);
  expect_solution(problem, X);
  ASSERT_EQ(report.steps.size(), calls);
  ASSERT_GE(calls, 2u);
  EXPECT_EQ(report.steps[0].active_set.active, 0u); // from X = 0: no contact
  EXPECT_EQ(report.steps[1].active_set.switched,
            report.steps[1].active_set.active);
  unsigned int n_contact = 0;
  for (unsigned int i = 0; i < problem.n; ++i)
    n_contact += X(i) - problem.psi(i) < 1e-12;
  for (const VI::NewtonStep &step : report.steps)
    EXPECT_TRUE(step.has_active_set);
  EXPECT_EQ(report.steps.back().active_set.active, n_contact);
}


namespace
{
  /// R(x) = atan(x) from x0 = 3: full Newton steps run away (|x| grows at
  /// every step from any |x0| > 1.39), so the merit 1/2 atan(x)^2 rises.
  VI::SemismoothNewton<Vector<double>>
  arctangent_newton(
    const typename VI::SemismoothNewton<Vector<double>>::AdditionalData &data)
  {
    VI::SemismoothNewton<Vector<double>> newton(data);
    auto                                 slope = std::make_shared<double>(1.);
    newton.residual = [](const Vector<double> &X, Vector<double> &R) {
      R(0) = std::atan(X(0));
      return VI::ResidualNorms{std::abs(R(0)), 0.};
    };
    newton.setup_jacobian = [slope](const Vector<double> &X) {
      *slope = 1. / (1. + X(0) * X(0));
    };
    newton.solve_with_jacobian = [slope](const Vector<double> &rhs,
                                         Vector<double>       &dX) {
      dX(0) = rhs(0) / *slope;
      return 0u;
    };
    return newton;
  }
} // namespace


TEST(SemismoothNewton, WatchdogReturnsToItsReferenceWhenFullStepsDiverge)
{
  typename VI::SemismoothNewton<Vector<double>>::AdditionalData data;
  data.tolerance      = 1e-12;
  data.line_search    = true;
  data.watchdog_steps = 3;
  Vector<double> X(1);
  X(0)              = 3.;
  const auto report = arctangent_newton(data).solve(X);
  EXPECT_LT(std::abs(X(0)), 1e-12);
  // Three full steps away from the root (the merit never falls below the
  // reference's), then back to x0 = 3 and a step cut by the line search.
  ASSERT_GT(report.steps.size(), 4u);
  for (unsigned int k = 0; k < 2; ++k)
    {
      EXPECT_EQ(report.steps[k].step_length, 1.);
      EXPECT_GT(report.steps[k].residual.equations, std::atan(3.));
    }
  EXPECT_EQ(report.steps[2].step_length, 0.);
  EXPECT_DOUBLE_EQ(report.steps[2].residual.equations, std::atan(3.));
  EXPECT_LT(report.steps[3].step_length, 1.);
  EXPECT_LT(report.steps[3].residual.equations, std::atan(3.));
  EXPECT_NE(VI::describe(report.steps[2]).find("watchdog"), std::string::npos);

  // Without the watchdog every step is cut from the start.
  data.watchdog_steps = 0;
  X(0)                = 3.;
  const auto armijo   = arctangent_newton(data).solve(X);
  EXPECT_LT(std::abs(X(0)), 1e-12);
  EXPECT_LT(armijo.steps[0].step_length, 1.);
  for (const VI::NewtonStep &step : armijo.steps)
    EXPECT_GT(step.step_length, 0.);
}


TEST(SemismoothNewton, ContinuationRecoversFromAStalledActiveSet)
{
  // From u = psi, lambda = 0 every node is a tie (for Fischer-Burmeister the
  // origin), hence active: the string lies on the obstacle, and
  // primal-dual active set steps free one node at each end per step (only
  // there does the multiplier change sign), about 0.35 (n + 1) steps to the
  // contact set [0.354, 0.646]. The continuation along the central path,
  // by either method, frees the whole set in a few steps, and ends on the
  // same discrete solution. Both C-functions take full steps, as in the
  // contact programs.
  const unsigned int n = 120;
  for (const auto type : {ComplementarityFunction::Type::min,
                          ComplementarityFunction::Type::fischer_burmeister})
    for (const auto method : {VI::ContinuationMethod::interior_point,
                              VI::ContinuationMethod::smoothing})
      {
        const std::string name =
          ComplementarityFunction(type).name() +
          (method == VI::ContinuationMethod::smoothing ? ", smoothing" :
                                                         ", interior point");
        ObstacleProblem problem(n, ComplementarityFunction(type));
        typename VI::SemismoothNewton<Vector<double>>::AdditionalData data;
        data.tolerance           = 1e-13;
        data.max_iterations      = 200;
        data.continuation_method = method;
        const auto active_set    = [&](const Vector<double> &X, bool) {
          return problem.stalling_active_set(X);
        };

        Vector<double> X_plain  = problem.on_the_obstacle();
        auto           plain    = problem.make_newton(data);
        plain.active_set        = active_set;
        const auto plain_report = plain.solve(X_plain);
        expect_solution(problem, X_plain);

        Vector<double> X      = problem.on_the_obstacle();
        auto           newton = problem.make_newton(data);
        newton.active_set     = active_set;
        if (method == VI::ContinuationMethod::smoothing)
          newton.set_smoothing = [&](const Vector<double> &X, const double mu) {
            problem.set_smoothing(X, mu);
          };
        else
          problem.attach_interior_point(newton);
        const auto report = newton.solve(X);
        expect_solution(problem, X);
        for (unsigned int i = 0; i < 2 * n; ++i)
          EXPECT_NEAR(X(i), X_plain(i), 1e-10) << name;
        EXPECT_GT(report.continuation_start, 0u) << name;
        EXPECT_EQ(plain_report.continuation_start, 0u);
        // It stops on the residual of C, with the rows of C again.
        EXPECT_LE(report.final_residual.complementarity, data.tolerance);
        EXPECT_FALSE(problem.interior);
        std::cout << name << ": " << plain_report.iterations << " plain steps, "
                  << report.iterations << " with the continuation (after step "
                  << report.continuation_start << ")" << std::endl;
        // Plain steps crawl (min 44, FB 47); the smoothing takes 20 and
        // 24 steps, the interior-point method 17 and 17.
        EXPECT_GE(plain_report.iterations, 35u) << name;
        EXPECT_LE(report.iterations,
                  method == VI::ContinuationMethod::interior_point ? 19u :
                  type == ComplementarityFunction::Type::min       ? 22u :
                                                                     26u)
          << name;
      }
}


TEST(SemismoothNewton, CentralityCorrectorsKeepTheSolution)
{
  // The stalled string of the test above on the interior-point path, with
  // and without Gondzio's corrector: the same solution, no more steps with
  // it, and a third solve in the steps that are cut short of the boundary.
  // (Here both take 17 steps, six with a corrector; on the contact meshes
  // it saves up to two steps: reference.md, "Continuation".)
  const unsigned int n = 120;
  for (const auto type : {ComplementarityFunction::Type::min,
                          ComplementarityFunction::Type::fischer_burmeister})
    {
      std::array<unsigned int, 2>   steps{}, solves{};
      std::array<Vector<double>, 2> X;
      for (const unsigned int correctors : {0u, 1u})
        {
          ObstacleProblem problem(n, ComplementarityFunction(type));
          typename VI::SemismoothNewton<Vector<double>>::AdditionalData data;
          data.tolerance             = 1e-13;
          data.max_iterations        = 200;
          data.centrality_correctors = correctors;
          X[correctors]              = problem.on_the_obstacle();
          auto newton                = problem.make_newton(data);
          newton.active_set          = [&](const Vector<double> &X, bool) {
            return problem.stalling_active_set(X);
          };
          newton.solve_with_jacobian = [&](const Vector<double> &rhs,
                                           Vector<double>       &dX) {
            ++solves[correctors];
            return problem.solve(rhs, dX);
          };
          problem.attach_interior_point(newton);
          const auto report = newton.solve(X[correctors]);
          expect_solution(problem, X[correctors]);
          ASSERT_GT(report.continuation_start, 0u);
          steps[correctors] = report.iterations;
          // (one solve per plain step, two per path step without correctors)
          solves[correctors] -=
            report.continuation_start +
            2 * (steps[correctors] - report.continuation_start);
        }
      for (unsigned int i = 0; i < 2 * n; ++i)
        EXPECT_NEAR(X[1](i), X[0](i), 1e-10);
      std::cout << ComplementarityFunction(type).name() << ": " << steps[0]
                << " steps without the corrector, " << steps[1] << " with it ("
                << solves[1] << " corrector solves)" << std::endl;
      EXPECT_LE(steps[1], steps[0]);
      EXPECT_EQ(solves[0], 0u);
      EXPECT_GT(solves[1], 0u);
    }
}


TEST(SemismoothNewton, InteriorPointToleratesInexactDirections)
{
  // The stalled string of the test above, each direction with an error of
  // 1e-2 of its size spread over all unknowns (as an iterative solve
  // stopped at a forcing term of 1e-2 leaves one). In the row of a pair
  // near the boundary, such an error blocks the step (measured without
  // InteriorPointRows::solve_rows: steps of 0.05, 3e-4, 9e-7, ... from
  // step 17 on, and no convergence in 200); with the rows solved exactly
  // Newton converges linearly, to the solution of exact Newton (24 and 23
  // steps).
  const unsigned int n = 120;
  for (const auto type : {ComplementarityFunction::Type::min,
                          ComplementarityFunction::Type::fischer_burmeister})
    {
      ObstacleProblem problem(n, ComplementarityFunction(type));
      typename VI::SemismoothNewton<Vector<double>>::AdditionalData data;
      data.tolerance      = 1e-13;
      data.max_iterations = 200;
      // (as the inexact strategies, without the centrality corrector)
      data.centrality_correctors = 0;
      Vector<double> X           = problem.on_the_obstacle();
      auto           newton      = problem.make_newton(data);
      newton.active_set          = [&](const Vector<double> &X, bool) {
        return problem.stalling_active_set(X);
      };
      Vector<double> error(2 * n);
      for (unsigned int i = 0; i < 2 * n; ++i)
        error(i) = std::sin(1.7 * i + 0.3);
      error /= error.l2_norm();
      newton.solve_with_jacobian = [&](const Vector<double> &rhs,
                                       Vector<double>       &dX) {
        problem.solve(rhs, dX);
        dX.add(1e-2 * dX.l2_norm(), error);
        return 0u;
      };
      problem.attach_interior_point(newton);
      const auto report = newton.solve(X);
      expect_solution(problem, X);
      EXPECT_GT(report.continuation_start, 0u);
      std::cout << ComplementarityFunction(type).name() << ": "
                << report.iterations << " inexact steps (continuation after "
                << report.continuation_start << ")" << std::endl;
      EXPECT_LE(report.iterations, 30u);
    }
}


TEST(SemismoothNewton, ContinuationStartsWhenTheActiveSetCrawlsOrCycles)
{
  // A scripted iteration, each step switching rows. Its complementarity
  // residual crawls (0.47, 0.33, 0.23, ...: a factor 0.7 a step, as a ring
  // crawl does), cycles (0.47, 0.22, 0.47, ...: as inexact directions made
  // it on the L-shape; no step crawls, since 0.22 is less than half of
  // 0.47, but the smallest residual stops falling), stagnates under the
  // inexact strategy (a factor 0.9 a step while the steps switch half as
  // many rows each time, as inexact steps that leave a ring's residual in
  // place do), converges
  // superlinearly (a factor 10 a step), or settles: it crawls, but
  // switches half as many rows each step, and the seventh step finds the
  // active set. The first three start the continuation, after crawl_steps,
  // cycle_steps and crawl_steps steps; on its path the script converges. The
  // next two converge by themselves. The last crawls under the adaptive
  // strategy, whose continuation waits adaptive_crawl_steps steps.
  enum class Script
  {
    crawl,
    cycle,
    stagnate,
    converge,
    settle,
    adaptive_crawl
  };
  for (const Script script : {Script::crawl,
                              Script::cycle,
                              Script::stagnate,
                              Script::converge,
                              Script::settle,
                              Script::adaptive_crawl})
    {
      VI::NonlinearSolverParameters parameters;
      parameters.max_iterations = 30;
      if (script == Script::adaptive_crawl)
        parameters.strategy = VI::Strategy::adaptive;
      if (script == Script::stagnate)
        parameters.strategy = VI::Strategy::inexact;
      parameters.continuation_method = VI::ContinuationMethod::smoothing;
      const VI::SemismoothNewton<Vector<double>>::AdditionalData data(
        parameters,
        ComplementarityFunction(ComplementarityFunction::Type::min));
      VI::SemismoothNewton<Vector<double>> newton(data);
      unsigned int                         evaluations = 0;
      bool                                 smoothed    = false;
      newton.residual = [&](const Vector<double> &, Vector<double> &R) {
        R = 0.;
        VI::ResidualNorms norms;
        norms.complementarity =
          smoothed ? 0. :
          script == Script::crawl || script == Script::adaptive_crawl ?
                     0.47 * std::pow(0.7, evaluations) :
          script == Script::cycle    ? (evaluations % 2 ? 0.22 : 0.47) :
          script == Script::stagnate ? 0.47 * std::pow(0.9, evaluations) :
          script == Script::converge ? 0.47 * std::pow(0.1, evaluations) :
          evaluations < 7            ? 0.47 * std::pow(0.7, evaluations) :
                                       0.;
        norms.smoothed_complementarity = norms.complementarity;
        ++evaluations;
        return norms;
      };
      newton.setup_jacobian      = [](const Vector<double> &) {};
      newton.solve_with_jacobian = [](const Vector<double> &,
                                      Vector<double> &dX) {
        dX = 0.;
        return 0u;
      };
      unsigned int linearisations = 0;
      newton.active_set           = [&](const Vector<double> &, const bool) {
        ++linearisations;
        return VI::ActiveSetChange{1000,
                                   script == Script::settle ||
                                       script == Script::stagnate ?
                                               640u >> linearisations :
                                               3u};
      };
      newton.set_smoothing = [&](const Vector<double> &, const double mu) {
        smoothed = smoothed || mu > 0;
      };
      Vector<double>         X(2);
      const VI::NewtonReport report = newton.solve(X);
      EXPECT_EQ(report.continuation_start,
                script == Script::crawl || script == Script::stagnate ?
                  data.crawl_steps + 1 :
                script == Script::cycle ? data.cycle_steps + 1 :
                script == Script::adaptive_crawl ?
                                          data.adaptive_crawl_steps + 1 :
                                          0u);
      if (script == Script::settle)
        {
          EXPECT_EQ(report.iterations, 7u);
        }
      EXPECT_LE(report.final_residual.complementarity, data.tolerance);
    }
}
