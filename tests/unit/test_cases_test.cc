// The data of the seed test cases satisfy the equations and the
// complementarity conditions they claim; expression data parse and fail as
// documented.
#include <deal.II/base/point.h>

#include <vi/errors.h>
#include <vi/test_cases.h>

#include <gtest/gtest.h>

#include "test_helpers.h"

#include <cmath>
#include <random>
#include <string>
#include <tuple>
#include <vector>

using dealii::Point;

namespace
{
  /// 9-point fourth-order finite-difference Laplacian.
  double
  laplacian(const dealii::Function<2> &u, const Point<2> &p, const double h)
  {
    double value = 0;
    for (unsigned int d = 0; d < 2; ++d)
      {
        dealii::Tensor<1, 2> e;
        e[d] = h;
        value += (-u.value(p + 2 * e) + 16 * u.value(p + e) - 30 * u.value(p) +
                  16 * u.value(p - e) - u.value(p - 2 * e)) /
                 (12 * h * h);
      }
    return value;
  }


  /// Sample points of the unit square not within `margin` of r = R.
  std::vector<Point<2>>
  sample_points(const double margin)
  {
    std::mt19937                           generator(42);
    std::uniform_real_distribution<double> uniform(0.01, 0.99);
    std::vector<Point<2>>                  points;
    while (points.size() < 200)
      {
        const Point<2> p(uniform(generator), uniform(generator));
        if (std::abs(p.distance(Point<2>(0.5, 0.5)) - 1. / 3.) > margin)
          points.push_back(p);
      }
    return points;
  }


  VI::MembraneData<2>
  seed_data(const std::string &name, const double mu1, const double mu2)
  {
    VI::ProblemParameters problem;
    problem.test_case = name;
    problem.mu1       = mu1;
    problem.mu2       = mu2;
    return VI::make_membrane_data<2>(problem, Point<2>(0.5, 0.5));
  }
} // namespace


class SeedTest : public ::testing::TestWithParam<std::string>
{
};


TEST_P(SeedTest, ForcesSatisfyTheEquationsForAnyTensions)
{
  const double mu1 = 2., mu2 = 0.5;
  const auto   data = seed_data(GetParam(), mu1, mu2);
  ASSERT_TRUE(data.has_exact_solution());
  ASSERT_TRUE(data.exact_lambda);
  for (const auto &p : sample_points(1e-2))
    {
      const double lambda = data.exact_lambda->value(p);
      // -mu1 Lap u1 - lambda = f1, -mu2 Lap u2 + lambda = f2
      EXPECT_NEAR(-mu1 * laplacian(*data.exact_u1, p, 1e-3) - lambda,
                  data.f1->value(p),
                  1e-6 * (1 + std::abs(data.f1->value(p))))
        << "at " << p;
      EXPECT_NEAR(-mu2 * laplacian(*data.exact_u2, p, 1e-3) + lambda,
                  data.f2->value(p),
                  1e-6 * (1 + std::abs(data.f2->value(p))))
        << "at " << p;
    }
}


TEST_P(SeedTest, ExactSolutionIsComplementary)
{
  const auto data = seed_data(GetParam(), 1., 1.);
  for (const auto &p : sample_points(0.))
    {
      const double gap    = data.exact_u1->value(p) - data.exact_u2->value(p);
      const double lambda = data.exact_lambda->value(p);
      EXPECT_GE(gap, 0.);
      EXPECT_GE(lambda, 0.);
      EXPECT_EQ(gap * lambda, 0.) << "at " << p;
    }
  // Contact on the disk r < R, none outside.
  EXPECT_GT(data.exact_lambda->value(Point<2>(0.5 + 0.2, 0.5)), 0.);
  EXPECT_GT(data.exact_u1->value(Point<2>(0.9, 0.9)) -
              data.exact_u2->value(Point<2>(0.9, 0.9)),
            0.);
}


TEST_P(SeedTest, GradientsMatchFiniteDifferences)
{
  const auto data = seed_data(GetParam(), 1., 1.);
  for (const auto *u : {data.exact_u1.get(), data.exact_u2.get()})
    for (const auto &p : sample_points(1e-3))
      {
        const auto gradient = u->gradient(p);
        for (unsigned int d = 0; d < 2; ++d)
          {
            dealii::Tensor<1, 2> e;
            e[d] = 1e-6;
            EXPECT_NEAR(gradient[d],
                        (u->value(p + e) - u->value(p - e)) / 2e-6,
                        1e-8);
          }
      }
}


TEST_P(SeedTest, BoundaryDataAreTheExactSolution)
{
  const auto data = seed_data(GetParam(), 1., 1.);
  for (const double t : {0., 0.3, 0.77, 1.})
    for (const Point<2> &p :
         {Point<2>(t, 0.), Point<2>(t, 1.), Point<2>(0., t), Point<2>(1., t)})
      {
        EXPECT_EQ(data.g1->value(p), data.exact_u1->value(p));
        EXPECT_EQ(data.g2->value(p), data.exact_u2->value(p));
        EXPECT_GE(data.g1->value(p), data.g2->value(p));
      }
}


INSTANTIATE_TEST_SUITE_P(TestCases,
                         SeedTest,
                         ::testing::Values("seed-smooth", "seed-jump"));


TEST(Expression, ReproducesTheSeedSmoothCase)
{
  VI::ProblemParameters problem;
  problem.test_case    = "expression";
  auto &e              = problem.expression;
  e.constants          = "R=0.333333333333333333, N=6, cx=0.5, cy=0.5";
  const std::string r2 = "((x-cx)^2+(y-cy)^2)";
  e.u1                 = r2 + ">=R^2 ? (" + r2 + "-R^2)^N : 0";
  e.u2                 = r2 + ">=R^2 ? -(" + r2 + "-R^2)^N : 0";
  e.g1                 = e.u1;
  e.g2                 = e.u2;
  e.f1                 = r2 + ">=R^2 ? -4*N*(" + r2 + "-R^2)^(N-2)*(N*" + r2 +
         "-R^2) : -1000*" + r2 + "^1.5*(R^2-" + r2 + ")^3";
  e.f2 = "-(" + e.f1 + ")";
  const auto expression =
    VI::make_membrane_data<2>(problem, Point<2>(0.5, 0.5));
  const auto seed = seed_data("seed-smooth", 1., 1.);
  ASSERT_TRUE(expression.has_exact_solution());
  EXPECT_FALSE(expression.exact_lambda);
  for (const auto &p : sample_points(1e-3))
    {
      EXPECT_NEAR(expression.f1->value(p), seed.f1->value(p), 1e-12);
      EXPECT_NEAR(expression.f2->value(p), seed.f2->value(p), 1e-12);
      EXPECT_NEAR(expression.exact_u1->value(p),
                  seed.exact_u1->value(p),
                  1e-14);
      // Fourth-order differences of the parsed u1 against the exact gradient.
      const auto g_parsed = expression.exact_u1->gradient(p);
      const auto g_exact  = seed.exact_u1->gradient(p);
      EXPECT_NEAR(g_parsed[0], g_exact[0], 1e-9);
      EXPECT_NEAR(g_parsed[1], g_exact[1], 1e-9);
    }
}


TEST(Expression, BadInputIsAnInputErrorNamingTheParameter)
{
  VI::ProblemParameters problem;
  problem.test_case  = "expression";
  problem.expression = {"0", "0", "0", "0", "", "", "", "", ""};

  // One bad entry each: the member of Problem/Expression, its text, and
  // what the error must say.
  using Entry = std::string VI::ExpressionParameters::*;
  const std::vector<std::tuple<Entry, std::string, std::string>> bad_inputs = {
    {&VI::ExpressionParameters::f2, "sin(x", "Problem/Expression/f2"},
    {&VI::ExpressionParameters::g1, "x + q", "Problem/Expression/g1"},
    {&VI::ExpressionParameters::constants,
     "R=0.3, N",
     "Problem/Expression/Constants"},
    {&VI::ExpressionParameters::u1, "x", "both exact solutions"},
    {&VI::ExpressionParameters::f1, " ", "Problem/Expression/f1 is empty"}};
  for (const auto &[entry, text, fragment] : bad_inputs)
    {
      VI::ProblemParameters bad = problem;
      bad.expression.*entry     = text;
      VITest::expect_error_saying<VI::InputError>(fragment, [&] {
        VI::make_membrane_data<2>(bad, Point<2>(0.5, 0.5));
      });
    }
}
