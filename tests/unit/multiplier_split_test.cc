// The cellwise split of the multiplier used by the estimators:
// lambda_h = c_K lambda_h^pos + delta (VI::split_multiplier).

#include <deal.II/base/quadrature_lib.h>

#include <vi/estimators.h>

#include <gtest/gtest.h>

#include <cmath>
#include <vector>

namespace
{
  // A Q2-like multiplier on the reference cell with an undershoot: the
  // values of 1 - a x (1 - x) - b y at the points of a Gauss rule.
  struct Sample
  {
    std::vector<double> lambda, JxW;
  };

  Sample
  sample(const double a, const double b, const double scale = 1.)
  {
    const dealii::QGauss<2> quadrature(4);
    Sample                  s;
    for (unsigned int q = 0; q < quadrature.size(); ++q)
      {
        const auto &p = quadrature.point(q);
        s.lambda.push_back(scale * (1. - a * p[0] * (1. - p[0]) - b * p[1]));
        s.JxW.push_back(quadrature.weight(q));
      }
    return s;
  }

  double
  integral(const std::vector<double> &f, const std::vector<double> &JxW)
  {
    double sum = 0;
    for (unsigned int q = 0; q < f.size(); ++q)
      sum += f[q] * JxW[q];
    return sum;
  }
} // namespace


TEST(MultiplierSplit, NonnegativeMultiplierIsKeptWhole)
{
  const Sample s     = sample(2., 0.5); // 1 - 2 x (1 - x) - y / 2 >= 0
  const auto   split = VI::split_multiplier(s.lambda, s.JxW);
  EXPECT_NEAR(split.cone_factor, 1., 1e-14);
  EXPECT_NEAR(split.oscillation_squared, 0., 1e-28);
  EXPECT_EQ(split.mean_squared, 0.);
}


TEST(MultiplierSplit, UndershootWithNonnegativeMeanHasZeroMeanRemainder)
{
  const Sample s     = sample(0., 1.8); // negative for y > 1/1.8, mean 0.1
  const auto   split = VI::split_multiplier(s.lambda, s.JxW);
  ASSERT_GT(split.cone_factor, 0.);
  ASSERT_LT(split.cone_factor, 1.);
  EXPECT_EQ(split.mean_squared, 0.);

  // delta = lambda - c lambda^pos has zero mean, and its norm is the
  // oscillation.
  std::vector<double> delta, delta_squared;
  for (const double l : s.lambda)
    {
      delta.push_back(l - split.cone_factor * std::max(l, 0.));
      delta_squared.push_back(delta.back() * delta.back());
    }
  EXPECT_NEAR(integral(delta, s.JxW), 0., 1e-14);
  EXPECT_NEAR(split.oscillation_squared, integral(delta_squared, s.JxW), 1e-14);
  // c lambda^pos >= 0 keeps the mean of lambda: 0.1 on the unit square.
  EXPECT_NEAR(integral(s.lambda, s.JxW), 0.1, 1e-14);
}


TEST(MultiplierSplit, NegativeMeanGoesToTheGlobalTerm)
{
  const Sample s     = sample(0., 3.); // mean 1 - 3/2 = -1/2
  const auto   split = VI::split_multiplier(s.lambda, s.JxW);
  EXPECT_EQ(split.cone_factor, 0.);
  EXPECT_NEAR(split.mean, -0.5, 1e-14);
  EXPECT_NEAR(split.mean_squared, 0.25, 1e-14);
  // delta = lambda, and |lambda - m|^2 = 9 |y - 1/2|^2 = 9 / 12.
  EXPECT_NEAR(split.oscillation_squared, 0.75, 1e-14);
}


TEST(MultiplierSplit, ScalesLinearly)
{
  const Sample s1 = sample(3., 0.4), s2 = sample(3., 0.4, 10.);
  const auto   a = VI::split_multiplier(s1.lambda, s1.JxW),
             b   = VI::split_multiplier(s2.lambda, s2.JxW);
  ASSERT_GT(a.cone_factor, 0.); // mean 0.3, negative near (1/2, 1)
  ASSERT_LT(a.cone_factor, 1.);
  EXPECT_NEAR(a.cone_factor, b.cone_factor, 1e-14);
  EXPECT_NEAR(100. * a.oscillation_squared, b.oscillation_squared, 1e-12);
}
