// The C-functions: zero set, gradients, generalised Jacobian at the kink.
#include <vi/complementarity.h>
#include <vi/errors.h>

#include <gtest/gtest.h>

#include <cmath>
#include <vector>

using VI::ComplementarityFunction;

namespace
{
  const std::vector<ComplementarityFunction> c_functions = {
    ComplementarityFunction(ComplementarityFunction::Type::min),
    ComplementarityFunction(ComplementarityFunction::Type::fischer_burmeister)};

  const std::vector<double> magnitudes =
    {1e-300, 1e-200, 1e-12, 1e-3, 1., 7.5, 1e8, 1e200, 1e300};
} // namespace


TEST(Complementarity, VanishesExactlyOnTheComplementaritySet)
{
  for (const auto &C : c_functions)
    for (const double a : magnitudes)
      {
        EXPECT_EQ(C.value(a, 0.), 0.) << C.name() << " a = " << a;
        EXPECT_EQ(C.value(0., a), 0.) << C.name() << " b = " << a;
      }
  for (const auto &C : c_functions)
    EXPECT_EQ(C.value(0., 0.), 0.) << C.name();
}


TEST(Complementarity, NonzeroOffTheComplementaritySet)
{
  // Both positive (complementarity violated), or one negative (sign
  // constraint violated), at every scale.
  for (const auto &C : c_functions)
    for (const double s : magnitudes)
      for (const auto &[a, b] : std::vector<std::pair<double, double>>{
             {1, 1}, {1, 1e-6}, {-1, 0}, {0, -1}, {-1, 2}, {2, -1}, {-1, -1}})
        {
          const double value = C.value(s * a, s * b);
          EXPECT_TRUE(std::isfinite(value)) << C.name() << " s = " << s;
          EXPECT_NE(value, 0.)
            << C.name() << " at (" << s * a << ", " << s * b << ")";
        }
}


TEST(Complementarity, FischerBurmeisterIsAccurateWhereItCancels)
{
  // For b << a the value is -b (1 + O(b/a)); the naive formula
  // sqrt(a^2+b^2) - a - b would lose all digits for b = 1e-12 a.
  const ComplementarityFunction C(
    ComplementarityFunction::Type::fischer_burmeister);
  const double a = 1., b = 1e-12;
  EXPECT_NEAR(C.value(a, b), -b, 1e-12 * b);
  // Positive homogeneity over 600 orders of magnitude.
  for (const double s : magnitudes)
    EXPECT_NEAR(C.value(s * 3., s * 4.) / s, 5. - 7., 1e-15);
}


TEST(Complementarity, GradientMatchesFiniteDifferencesAwayFromTheKink)
{
  const std::vector<std::pair<double, double>> points = {
    {1, 2}, {2, 1}, {-1, 3}, {3, -1}, {-2, -0.5}, {0.3, -0.7}, {1e-3, 5}};
  for (const auto &C : c_functions)
    for (const auto &[a, b] : points)
      {
        const double h  = 1e-6;
        const auto   g  = C.generalized_gradient(a, b);
        const double da = (C.value(a + h, b) - C.value(a - h, b)) / (2. * h);
        const double db = (C.value(a, b + h) - C.value(a, b - h)) / (2. * h);
        EXPECT_NEAR(g[0], da, 1e-7)
          << C.name() << " at (" << a << ", " << b << ")";
        EXPECT_NEAR(g[1], db, 1e-7)
          << C.name() << " at (" << a << ", " << b << ")";
      }
}


TEST(Complementarity, MinJacobianAtTheKinkIsALimitOfGradients)
{
  // On a = b, Clarke's Jacobian of min is conv{(1,0), (0,1)}; the element
  // returned must be the gradient of one of the two sides.
  const ComplementarityFunction C(ComplementarityFunction::Type::min);
  for (const double a : {-1., 0., 1e-8, 2.})
    {
      const auto g      = C.generalized_gradient(a, a);
      const auto left   = C.generalized_gradient(a - 1e-3, a);
      const auto right  = C.generalized_gradient(a + 1e-3, a);
      const bool is_one = (g == left) || (g == right);
      EXPECT_TRUE(is_one) << "a = " << a;
      EXPECT_DOUBLE_EQ(g[0] + g[1], 1.);
    }
}


TEST(Complementarity, FischerBurmeisterJacobianAtTheOriginIsInTheClarkeSet)
{
  // Clarke's Jacobian of FB at (0, 0): {(xi - 1, zeta - 1): xi^2 + zeta^2 <=
  // 1}.
  const ComplementarityFunction C(
    ComplementarityFunction::Type::fischer_burmeister);
  const auto   g  = C.generalized_gradient(0., 0.);
  const double xi = g[0] + 1., zeta = g[1] + 1.;
  EXPECT_LE(xi * xi + zeta * zeta, 1. + 1e-15);
  // ... and it is the limit of gradients from the contact side, where it
  // enforces the gap as min's tie does.
  const auto near = C.generalized_gradient(0., 1e-10);
  EXPECT_NEAR(g[0], near[0], 1e-12);
  EXPECT_NEAR(g[1], near[1], 1e-12);
  // Away from the origin the gradient has the same form, on the circle.
  const auto   h   = C.generalized_gradient(3., -4.);
  const double xi2 = h[0] + 1., zeta2 = h[1] + 1.;
  EXPECT_NEAR(xi2 * xi2 + zeta2 * zeta2, 1., 1e-15);
}


TEST(Complementarity, FreeSideAtTheOriginIsTheLimitAlongTheFreeHalfLine)
{
  // The other end of the Clarke set at (0, 0): the row enforces b = 0, and
  // it is the gradient's limit along a > 0, b = 0 (for a cold start).
  for (const auto type : {ComplementarityFunction::Type::min,
                          ComplementarityFunction::Type::fischer_burmeister})
    {
      const ComplementarityFunction C(type);
      const auto                    g    = C.free_side_gradient_at_origin();
      const auto                    near = C.generalized_gradient(1e-10, 0.);
      EXPECT_EQ(g[0], 0.);
      EXPECT_EQ(std::abs(g[1]), 1.);
      EXPECT_NEAR(g[0], near[0], 1e-12);
      EXPECT_NEAR(g[1], near[1], 1e-12);
      // and not the element the kink has elsewhere (the contact side)
      EXPECT_NE(g[0], C.generalized_gradient(0., 0.)[0]);
    }
}


TEST(Complementarity, NamesRoundTrip)
{
  for (const auto &C : c_functions)
    EXPECT_EQ(ComplementarityFunction::from_name(C.name()).type(), C.type());
  EXPECT_THROW(ComplementarityFunction::from_name("max"), VI::InputError);
}


TEST(Complementarity, SmoothingVanishesOnTheCentralPath)
{
  // C_mu(x, y) = 0 exactly for x, y > 0, x y = mu^2, and not elsewhere.
  for (const auto &C : c_functions)
    for (const double mu : {1e-12, 1e-6, 1e-2, 1.})
      for (const double x : {1e-3 * mu, mu, 1e3 * mu})
        {
          const double y = mu * mu / x;
          EXPECT_NEAR(C.smoothed_value(x, y, mu), 0., 1e-15 * (x + y))
            << C.name() << " mu = " << mu << " x = " << x;
          EXPECT_GT(std::abs(C.smoothed_value(x, 2. * y, mu)), 0.)
            << C.name() << " mu = " << mu << " x = " << x;
          EXPECT_GT(std::abs(C.smoothed_value(-x, -y, mu)), 0.)
            << C.name() << " mu = " << mu << " x = " << x;
        }
}


TEST(Complementarity, SmoothingTendsToTheCFunction)
{
  // |C_mu - C| <= mu (CHKS: exactly mu on the diagonal; Kanzow's FB: at
  // most sqrt(2) mu - a bound of the same order).
  const std::vector<std::pair<double, double>> points = {
    {1, 2}, {2, 1}, {-1, 3}, {3, -1}, {-2, -0.5}, {0., 0.}, {1e-3, 5}};
  for (const auto &C : c_functions)
    for (const double mu : {1e-1, 1e-4, 1e-8})
      for (const auto &[x, y] : points)
        EXPECT_LE(std::abs(C.smoothed_value(x, y, mu) - C.value(x, y)),
                  std::sqrt(2.) * mu * (1. + 1e-12))
          << C.name() << " mu = " << mu << " at (" << x << ", " << y << ")";
}


TEST(Complementarity, SmoothedGradientMatchesFiniteDifferences)
{
  const std::vector<std::pair<double, double>> points = {
    {1, 2}, {2, 1}, {-1, 3}, {0., 0.}, {1e-3, 1e-3}, {0.3, -0.7}};
  for (const auto &C : c_functions)
    for (const double mu : {1e-2, 0.5})
      for (const auto &[x, y] : points)
        {
          const double h = 1e-7;
          const auto   g = C.smoothed_gradient(x, y, mu);
          EXPECT_NEAR(g[0],
                      (C.smoothed_value(x + h, y, mu) -
                       C.smoothed_value(x - h, y, mu)) /
                        (2. * h),
                      1e-6)
            << C.name() << " at (" << x << ", " << y << ")";
          EXPECT_NEAR(g[1],
                      (C.smoothed_value(x, y + h, mu) -
                       C.smoothed_value(x, y - h, mu)) /
                        (2. * h),
                      1e-6)
            << C.name() << " at (" << x << ", " << y << ")";
        }
}
