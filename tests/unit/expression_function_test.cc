// VI::ExpressionFunction gives the values of deal.II's FunctionParser, and
// its gradients (fourth-order differences) to the last bit where those have
// converged (the differences of steps h and h/4 agree), also when two
// threads share one object; near a singularity closer than h it takes a
// smaller step and gets the gradient right; it reports bad formulas as
// InputError.
#include <deal.II/base/function_parser.h>
#include <deal.II/base/numbers.h>
#include <deal.II/base/point.h>
#include <deal.II/base/thread_management.h>

#include <vi/errors.h>
#include <vi/expression_function.h>

#include <gtest/gtest.h>

#include <cmath>
#include <map>
#include <memory>
#include <string>
#include <vector>

using dealii::Point;
using dealii::Tensor;

namespace
{
  // The exact solution of the [DMV20] disk scene: both branches, the
  // ternary and powers of subexpressions; and one with deal.II's extra
  // functions, atan2 and t.
  const std::string disk =
    "x^2+y^2 >= R^2 ? (x^2+y^2-R^2)^3 : -A*(R^2-x^2-y^2)^2";
  const std::string extras =
    "if(x > y, pow(x, 3), floor(4*y)) + erfc(x) + atan2(-x, y) + log(2+y) "
    "+ t*sec(x)";
  const std::map<std::string, double> constants = {{"R", 0.5},
                                                   {"A", 10},
                                                   {"pi", dealii::numbers::PI}};

  std::vector<Point<2>>
  points()
  {
    std::vector<Point<2>> p;
    for (unsigned int i = 0; i < 400; ++i)
      p.emplace_back(0.9 * std::sin(0.37 * i), 0.9 * std::cos(0.61 * i));
    return p;
  }

  std::unique_ptr<dealii::FunctionParser<2>>
  deal_ii_parser(const std::string &formula,
                 const bool         time_dependent,
                 const double       h = 1e-4)
  {
    auto parser = std::make_unique<dealii::FunctionParser<2>>(1, 0., h);
    parser->set_formula(dealii::AutoDerivativeFunction<2>::FourthOrder);
    parser->initialize(time_dependent ? "x,y,t" : "x,y",
                       formula,
                       constants,
                       time_dependent);
    return parser;
  }
} // namespace


TEST(ExpressionFunction, EqualsFunctionParserBitForBit)
{
  for (const bool time_dependent : {false, true})
    {
      const std::string formula   = time_dependent ? extras : disk;
      const auto        parser    = deal_ii_parser(formula, time_dependent);
      auto             &reference = *parser;
      VI::ExpressionFunction<2> f(
        formula, constants, Point<2>(), time_dependent, 1e-4);
      reference.set_time(0.25);
      f.set_time(0.25);

      // FunctionParser with step h/4: where its gradient agrees with that
      // of step h, the function is smooth around the point.
      const auto finer = deal_ii_parser(formula, time_dependent, 0.25e-4);
      finer->set_time(0.25);

      const auto                p = points();
      std::vector<double>       values(p.size());
      std::vector<Tensor<1, 2>> gradients(p.size());
      f.value_list(p, values);
      f.gradient_list(p, gradients);
      unsigned int smooth = 0;
      for (std::size_t q = 0; q < p.size(); ++q)
        {
          EXPECT_EQ(values[q], reference.value(p[q])) << formula;
          EXPECT_EQ(f.value(p[q]), values[q]);
          EXPECT_EQ(f.gradient(p[q]), gradients[q]);
          const Tensor<1, 2> g = reference.gradient(p[q]);
          if ((g - finer->gradient(p[q])).norm() > 1e-6 * (g.norm() + 1.))
            continue;
          ++smooth;
          EXPECT_EQ(gradients[q][0], g[0]) << formula;
          EXPECT_EQ(gradients[q][1], g[1]) << formula;
        }
      EXPECT_GE(smooth, 390u) << formula;
    }
}


// The L-shape's corner singularity r^(2/3) sin(2 theta / 3) at points 1e-5
// and 1e-6 from the corner, closer than the step h = 1e-4: FunctionParser's
// differences straddle the corner and miss the gradient, the smaller steps
// get it to 1e-6. (The smallest step, h / 4^8, reaches about 1e-6.)
TEST(ExpressionFunction, GradientNearACornerSingularity)
{
  const std::string corner = "(x^2+y^2)^(1/3)*sin(2/3*atan2(y, x))";
  const VI::ExpressionFunction<2> f(
    corner, constants, Point<2>(1, 1), false, 1e-4);
  const auto parser = deal_ii_parser(corner, false);
  for (const double r : {1e-5, 1e-6})
    {
      const double   theta = 1.;
      const Point<2> p(r * std::cos(theta), r * std::sin(theta));
      // grad = (2/3) r^(-1/3) (-sin(theta/3), cos(theta/3)) in x, y
      const double       c = 2. / 3. * std::pow(r, -1. / 3.);
      const Tensor<1, 2> exact(
        {-c * std::sin(theta / 3), c * std::cos(theta / 3)});
      EXPECT_LE((f.gradient(p) - exact).norm(), 1e-6 * exact.norm()) << r;
      if (r == 1e-5)
        {
          EXPECT_GE((parser->gradient(p) - exact).norm(), 0.1 * exact.norm());
        }
    }
}


// A kink 1.5 h from the point, between the stencil's inner and outer
// points: the second-order differences of the inner points are exact
// (slope -1) and the fourth-order ones are not (-13/12), so the stencil's
// own check must send the point to the smaller steps.
TEST(ExpressionFunction, GradientNextToAKinkBetweenTheStencilsPoints)
{
  const std::string               kink = "abs(x - 1.5e-4)";
  const VI::ExpressionFunction<2> f(
    kink, constants, Point<2>(1, 1), false, 1e-4);
  const auto         parser = deal_ii_parser(kink, false);
  const Point<2>     p(0., 0.5);
  const Tensor<1, 2> exact({-1., 0.});
  EXPECT_LE((f.gradient(p) - exact).norm(), 1e-9);
  EXPECT_NEAR(parser->gradient(p)[0], -13. / 12., 1e-9);
}


TEST(ExpressionFunction, TwoThreadsSharingOneObjectGetTheSameNumbers)
{
  const VI::ExpressionFunction<2> f(disk, constants, Point<2>(), false, 1e-4);
  const auto                      p = points();
  std::vector<Tensor<1, 2>>       alone(p.size());
  f.gradient_list(p, alone);

  // Both threads evaluate all points, list by list, at the same time.
  std::vector<Tensor<1, 2>> first(p.size()), second(p.size());
  const auto                work = [&](std::vector<Tensor<1, 2>> &result) {
    std::vector<Point<2>>     cell(16);
    std::vector<Tensor<1, 2>> g(16);
    for (std::size_t begin = 0; begin + 16 <= p.size(); begin += 16)
      {
        std::copy(p.begin() + begin, p.begin() + begin + 16, cell.begin());
        f.gradient_list(cell, g);
        std::copy(g.begin(), g.end(), result.begin() + begin);
      }
  };
  dealii::Threads::Task<void> other =
    dealii::Threads::new_task([&]() { work(second); });
  work(first);
  other.join();
  for (std::size_t q = 0; q < p.size(); ++q)
    {
      EXPECT_EQ(first[q], alone[q]);
      EXPECT_EQ(second[q], alone[q]);
    }
}


TEST(ExpressionFunction, BadFormulasAreInputErrorsWithMuparsersDiagnosis)
{
  const auto message = [](const std::string &formula) -> std::string {
    try
      {
        VI::ExpressionFunction<2> f(
          formula, constants, Point<2>(), false, 1e-4);
      }
    catch (const VI::InputError &error)
      {
        return error.what();
      }
    return "no error";
  };
  EXPECT_EQ(message("sin(x"),
            "Missing parenthesis (at the end of the formula)");
  EXPECT_EQ(message("x + (y"),
            "Missing parenthesis (at the end of the formula)");
  EXPECT_EQ(message("(x + y)) * 2"),
            "Unexpected parenthesis \")\" at position 7");
  EXPECT_EQ(message("x + q"), "Unexpected token \"q\" found at position 4.");
  // t is a variable only of time-dependent functions
  EXPECT_EQ(message("x + t"), "Unexpected token \"t\" found at position 4.");
  EXPECT_EQ(message(""), "Expression is empty.");
}


// The Laplacian by fourth-order second differences (the third bound of the
// estimate over a smooth obstacle needs it): that of the obstacle of the
// radial test, sqrt(1 - r^2), is -(2 - r^2) / (1 - r^2)^(3/2), here within
// 1e-7 relative inside r <= 0.9, and a quadratic's is exact to rounding.
TEST(ExpressionFunction, LaplacianOfSmoothFunctions)
{
  VI::ExpressionFunction<2> cap(
    "sqrt(1 - x^2 - y^2)", {}, Point<2>(), false, 1e-4);
  VI::ExpressionFunction<2> quadratic(
    "3*x^2 - x*y + 2*y^2 + x", {}, Point<2>(), false, 1e-4);
  for (const Point<2> &p : points())
    {
      const double r2 = p.norm_square();
      if (r2 <= 0.81)
        {
          const double exact = -(2 - r2) / std::pow(1 - r2, 1.5);
          EXPECT_NEAR(cap.laplacian(p), exact, 1e-7 * std::abs(exact));
        }
      EXPECT_NEAR(quadratic.laplacian(p), 10., 1e-6);
    }
}
