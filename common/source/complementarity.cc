#include <vi/complementarity.h>
#include <vi/errors.h>
#include <vi/spellings.h>

#include <cmath>

namespace VI
{
  ComplementarityFunction::ComplementarityFunction(const Type type)
      : SpeltChoice(type)
  {
  }


  const Spellings<ComplementarityType> &
  ComplementarityFunction::spellings()
  {
    static const Spellings<Type> c_functions = {{Type::min, "min"},
                                                {Type::fischer_burmeister,
                                                 "fischer-burmeister"}};
    return c_functions;
  }


  ComplementarityFunction
  ComplementarityFunction::from_name(const std::string &name)
  {
    if (const auto type = value_spelt(spellings(), name))
      return ComplementarityFunction(*type);
    throw InputError("Unknown C-function <" + name +
                     ">; accepted values: " + names());
  }


  double
  ComplementarityFunction::value(const double a, const double b) const
  {
    if (type_ == Type::min)
      return std::min(a, b);

    // FB is positively homogeneous, FB(a, b) = s FB(a/s, b/s), so it is
    // evaluated on arguments scaled to [-1, 1]: no overflow or underflow for
    // data of extreme size. For a, b > 0 the form sqrt(a^2 + b^2) - (a + b)
    // cancels catastrophically when one argument is small; the equivalent
    // -2ab / (sqrt(a^2 + b^2) + a + b) is accurate there and vanishes exactly
    // when a = 0 or b = 0.
    const double s = std::max(std::abs(a), std::abs(b));
    if (s == 0.)
      return 0.;
    const double x = a / s, y = b / s, r = std::hypot(x, y);
    if (x + y > 0)
      return s * (-2. * x * y / (r + x + y));
    return s * (r - x - y);
  }


  std::array<double, 2>
  ComplementarityFunction::generalized_gradient(const double a,
                                                const double b) const
  {
    if (type_ == Type::min)
      return (a <= b) ? std::array<double, 2>{{1., 0.}} :
                        std::array<double, 2>{{0., 1.}};

    const double r = std::hypot(a, b);
    if (r > 0)
      return {{a / r - 1., b / r - 1.}};
    // At the origin, the limit from the contact side (a = 0, b > 0): the row
    // enforces a = 0, as min's does at its tie. The contact set of a data
    // guess (lambda = 0) sits there; the limit along the diagonal,
    // (xi - 1)(1, 1), would impose a + b = 0 instead, a coupling whose
    // weight depends on the units of a and b (from the data guess on
    // 128 x 128 cells: 17 steps instead of 6). A cold start, every row at
    // the origin, takes the free side instead (ContactRows).
    return {{-1., 0.}};
  }


  std::array<double, 2>
  ComplementarityFunction::free_side_gradient_at_origin() const
  {
    // Both functions are smooth on the open half-line a > 0, b = 0.
    return generalized_gradient(1., 0.);
  }


  bool
  ComplementarityFunction::has_smooth_merit_function() const
  {
    return type_ == Type::fischer_burmeister;
  }


  // Both smoothings are evaluated in the form that does not cancel: for the
  // min-function, (x + y - s) / 2 = 2 (x y - mu^2) / (x + y + s) when
  // x + y > 0; for Fischer-Burmeister, s - x - y = (2 mu^2 - 2 x y) /
  // (s + x + y) when x + y > 0. Both vanish to round-off on x y = mu^2.
  double
  ComplementarityFunction::smoothed_value(const double x,
                                          const double y,
                                          const double mu) const
  {
    if (type_ == Type::min)
      {
        const double s = std::sqrt((x - y) * (x - y) + 4. * mu * mu);
        return x + y > 0 ? 2. * (x * y - mu * mu) / (x + y + s) :
                           0.5 * (x + y - s);
      }
    const double s = std::sqrt(x * x + y * y + 2. * mu * mu);
    return x + y > 0 ? 2. * (mu * mu - x * y) / (s + x + y) : s - x - y;
  }


  std::array<double, 2>
  ComplementarityFunction::smoothed_gradient(const double x,
                                             const double y,
                                             const double mu) const
  {
    if (type_ == Type::min)
      {
        const double s = std::sqrt((x - y) * (x - y) + 4. * mu * mu);
        if (s == 0.)
          return {{0.5, 0.5}};
        return {{0.5 * (1. - (x - y) / s), 0.5 * (1. + (x - y) / s)}};
      }
    const double s = std::sqrt(x * x + y * y + 2. * mu * mu);
    if (s == 0.)
      {
        const double xi = 1. / std::sqrt(2.);
        return {{xi - 1., xi - 1.}};
      }
    return {{x / s - 1., y / s - 1.}};
  }
} // namespace VI
