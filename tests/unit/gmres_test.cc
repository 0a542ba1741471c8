// The GMRES of linear_solvers.h on a nonsymmetric system (1D convection-
// diffusion), with deal.II vectors.
#include <deal.II/lac/full_matrix.h>
#include <deal.II/lac/vector.h>

#include <vi/errors.h>
#include <vi/linear_solvers.h>

#include <gtest/gtest.h>

#include <cmath>
#include <memory>
#include <vector>

using dealii::FullMatrix;
using dealii::Vector;
using Solver = VI::Gmres<Vector<double>>;

namespace
{
  struct System
  {
    explicit System(const unsigned int n)
        : A(n, n)
        , b(n)
    {
      const double h = 1. / (n + 1), peclet = 20.;
      for (unsigned int i = 0; i < n; ++i)
        {
          A(i, i) = 2. / (h * h);
          if (i > 0)
            A(i, i - 1) = -1. / (h * h) - peclet / (2 * h);
          if (i + 1 < n)
            A(i, i + 1) = -1. / (h * h) + peclet / (2 * h);
          b(i) = std::sin(3. * i * h) + 1.;
        }
    }

    Solver::Operator
    op() const
    {
      return [this](Vector<double> &dst, const Vector<double> &src) {
        A.vmult(dst, src);
      };
    }

    Solver::Operator
    jacobi() const
    {
      return [this](Vector<double> &dst, const Vector<double> &src) {
        for (unsigned int i = 0; i < src.size(); ++i)
          dst(i) = src(i) / A(i, i);
      };
    }

    double
    residual(const Vector<double> &x) const
    {
      Vector<double> r(b.size());
      A.vmult(r, x);
      r -= b;
      return r.l2_norm();
    }

    FullMatrix<double> A;
    Vector<double>     b;
  };
} // namespace


TEST(Gmres, ConvergesWithAndWithoutRestarts)
{
  const System system(60);
  for (const unsigned int krylov_dimension : {100u, 15u})
    {
      Solver::AdditionalData data;
      data.krylov_dimension   = krylov_dimension;
      data.relative_tolerance = 1e-10;
      data.max_iterations     = 2000;
      Vector<double> x(60);
      const auto     report =
        Solver(data).solve(system.op(), system.jacobi(), x, system.b);
      EXPECT_EQ(report.outcome, VI::LinearSolveReport::Outcome::converged);
      EXPECT_LE(system.residual(x), 1e-10 * system.b.l2_norm() * 1.01)
        << "Krylov dimension " << krylov_dimension;
      if (krylov_dimension >= 60)
        {
          EXPECT_LE(report.iterations, 60u); // full GMRES: at most n steps
        }
    }
}


TEST(Gmres, MonitorSeesTheCurrentMinimalResidualIterate)
{
  // Full GMRES minimises |b - A x| over growing Krylov spaces: the residuals
  // of the iterates handed to the monitor decrease, and equal the residual
  // GMRES reports.
  const System           system(80);
  Solver::AdditionalData data;
  data.check_interval     = 5;
  data.relative_tolerance = 1e-12;
  std::vector<double>       residuals;
  std::vector<unsigned int> steps;
  Vector<double>            x(80);
  Solver(data).solve(system.op(),
                     system.jacobi(),
                     x,
                     system.b,
                     [&](const Vector<double> &current, const unsigned int i) {
                       residuals.push_back(system.residual(current));
                       steps.push_back(i);
                       return false;
                     });
  ASSERT_GE(residuals.size(), 3u);
  for (std::size_t n = 0; n < steps.size(); ++n)
    EXPECT_EQ(steps[n], 5 * (n + 1));
  for (std::size_t n = 1; n < residuals.size(); ++n)
    EXPECT_LE(residuals[n], residuals[n - 1] * (1 + 1e-12));
}


TEST(Gmres, MonitorCanStopWithTheCurrentIterate)
{
  const System           system(80);
  Solver::AdditionalData data;
  data.check_interval = 10;
  Vector<double> x(80), seen(80);
  const auto     report = Solver(data).solve(system.op(),
                                         system.jacobi(),
                                         x,
                                         system.b,
                                         [&](const Vector<double> &current,
                                             const unsigned int    i) {
                                           seen = current;
                                           return i == 20;
                                         });
  EXPECT_EQ(report.outcome, VI::LinearSolveReport::Outcome::stopped_by_caller);
  EXPECT_EQ(report.iterations, 20u);
  for (unsigned int i = 0; i < 80; ++i)
    EXPECT_EQ(x(i), seen(i));
  EXPECT_NEAR(system.residual(x),
              report.final_residual,
              1e-8 * report.initial_residual);
}


TEST(Gmres, ScheduleAddsChecksAtTheResidualItSees)
{
  // The schedule sees every iteration's residual, which is that of the
  // iterate the monitor gets; checks come where it asks and, between, at
  // most check_interval iterations apart.
  const System           system(80);
  Solver::AdditionalData data;
  data.check_interval     = 7;
  data.relative_tolerance = 1e-12;
  std::vector<unsigned int> asked_at, checked_at;
  std::vector<double>       residuals(1);
  Vector<double>            x(80);
  Solver(data).solve(
    system.op(),
    system.jacobi(),
    x,
    system.b,
    [&](const Vector<double> &current, const unsigned int i) {
      checked_at.push_back(i);
      EXPECT_NEAR(system.residual(current), residuals[i], 1e-8 * residuals[1]);
      return false;
    },
    [&](const unsigned int i, const double residual, const double initial) {
      EXPECT_EQ(residuals.size(), i);
      EXPECT_DOUBLE_EQ(initial, system.residual(Vector<double>(80)));
      residuals.push_back(residual);
      if (i == 2 || i == 3)
        asked_at.push_back(i);
      return i == 2 || i == 3;
    });
  ASSERT_EQ(asked_at.size(), 2u);
  ASSERT_GE(checked_at.size(), 4u);
  EXPECT_EQ(checked_at[0], 2u);
  EXPECT_EQ(checked_at[1], 3u);
  EXPECT_EQ(checked_at[2], 10u);
  EXPECT_EQ(checked_at[3], 17u);
}


TEST(Gmres, IterationLimitIsAFailure)
{
  const System           system(80);
  Solver::AdditionalData data;
  data.max_iterations     = 5;
  data.relative_tolerance = 1e-12;
  Vector<double> x(80);
  EXPECT_THROW(Solver(data).solve(system.op(), system.jacobi(), x, system.b),
               VI::SolverFailure);
}


namespace
{
  /// The exact inverse of A as a preconditioner, plus an error of size
  /// `noise` |A^-1 b| that changes with every application (a preconditioner
  /// that is not a fixed linear operator, whose error no GMRES cycle can
  /// remove).
  Solver::Operator
  inverse(const System &system, const double noise)
  {
    auto A_inverse = std::make_shared<FullMatrix<double>>(system.A);
    A_inverse->gauss_jordan();
    Vector<double> solution(system.b.size());
    A_inverse->vmult(solution, system.b);
    const double error = noise * solution.l2_norm();
    auto         calls = std::make_shared<unsigned int>(0);
    return [A_inverse, error, calls](Vector<double>       &dst,
                                     const Vector<double> &src) {
      A_inverse->vmult(dst, src);
      ++*calls;
      for (unsigned int i = 0; i < dst.size(); ++i)
        dst(i) += error * std::sin(7. * i + *calls);
    };
  }


  /// GMRES on `system` preconditioned by inverse(system, noise), to a
  /// relative tolerance, with a limit no test reaches.
  VI::LinearSolveReport
  solve_with_inverse(const System   &system,
                     const double    noise,
                     const double    relative_tolerance,
                     Vector<double> &x)
  {
    Solver::AdditionalData data;
    data.relative_tolerance = relative_tolerance;
    data.max_iterations     = 1000;
    return Solver(data).solve(system.op(), inverse(system, noise), x, system.b);
  }
} // namespace


TEST(Gmres, StopsAtTheRoundingLevelOfTheSystem)
{
  // A tolerance below what double precision can reach: with the exact
  // inverse the first step solves the system, and the next cycle finds the
  // true residual where rounding leaves it. That solution is returned at
  // once, not after max_iterations of repeated cycles.
  const System   system(60);
  Vector<double> x(60);
  const auto     report = solve_with_inverse(system, 0., 1e-20, x);
  EXPECT_EQ(report.outcome, VI::LinearSolveReport::Outcome::stagnated);
  EXPECT_LE(report.iterations, 5u);
  EXPECT_LE(system.residual(x), 1e-12 * system.b.l2_norm());
}


TEST(Gmres, ReportsTheStagnatedResidual)
{
  // A preconditioner with errors of 1e-6: the recurrence converges, the
  // true residual stays near 1e-6 of the initial one, and the report says
  // where.
  const System   system(60);
  Vector<double> x(60);
  const auto     report = solve_with_inverse(system, 1e-6, 1e-10, x);
  EXPECT_EQ(report.outcome, VI::LinearSolveReport::Outcome::stagnated);
  EXPECT_LE(report.iterations, 10u);
  EXPECT_GT(report.final_residual, 1e-8 * report.initial_residual);
  EXPECT_NEAR(system.residual(x), report.final_residual, 1e-12);
}
