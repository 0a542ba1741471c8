#pragma once

#include <vi/spellings.h>

#include <array>
#include <string>

namespace VI
{
  /// The complementarity functions of ComplementarityFunction.
  enum class ComplementarityType
  {
    min,
    fischer_burmeister
  };

  /**
   * A complementarity function (C-function) C : R^2 -> R, characterised by
   *
   *   C(a, b) = 0   <=>   a >= 0,  b >= 0,  a b = 0.
   *
   * Writing each constraint row of a discrete variational inequality as
   * C(a_l, b_l) = 0 (for the membranes a_l = X1_l - X2_l, b_l = X3_l) turns
   * the inequality system into a nonsmooth system of equations, solved by
   * semismooth Newton. Both functions are semismooth, so Newton converges
   * locally superlinearly with any element of the generalised Jacobian;
   * Newton-min converges in finitely many steps on the membrane problem.
   *
   * - min(a, b): piecewise linear; Newton-min is the primal-dual active set
   *   method. Its merit function 1/2 |C|^2 is not differentiable, so it is
   *   used without line search.
   * - Fischer-Burmeister: sqrt(a^2 + b^2) - a - b, smooth except at (0, 0);
   *   1/2 |C|^2 is continuously differentiable, which is what makes a
   *   backtracking line search on it meaningful.
   */
  class ComplementarityFunction
      : public SpeltChoice<ComplementarityFunction, ComplementarityType>
  {
  public:
    using Type = ComplementarityType;

    explicit ComplementarityFunction(const Type type = Type::min);

    /// Parse "min" or "fischer-burmeister" (the .prm spelling).
    static ComplementarityFunction
    from_name(const std::string &name);

    /// "min" and "fischer-burmeister": names(), name().
    static const Spellings<Type> &
    spellings();

    double
    value(const double a, const double b) const;

    /**
     * An element (dC/da, dC/db) of the generalised (Clarke) Jacobian of C at
     * (a, b). Away from the kink this is the gradient. At the kink:
     * - min, a == b: (1, 0), a limit of gradients from the side a < b, so the
     *   constraint a = 0 is enforced (the node is treated as in contact);
     * - Fischer-Burmeister, (0, 0): (-1, 0), the limit of gradients from
     *   the side a = 0, b > 0, so that, as for min, the node is treated as
     *   in contact.
     */
    std::array<double, 2>
    generalized_gradient(const double a, const double b) const;

    /**
     * The other end of the generalised Jacobian at the origin: the limit of
     * gradients from the free side a > 0, b = 0, (0, 1) for min and (0, -1)
     * for Fischer-Burmeister, whose row enforces b = 0 (the node is treated
     * as free). For a cold start (ContactRows::set_linearisation_point).
     */
    std::array<double, 2>
    free_side_gradient_at_origin() const;

    /// True if 1/2 |C|^2 is continuously differentiable (Fischer-Burmeister).
    bool
    has_smooth_merit_function() const;

    /**
     * The smoothing C_mu of C (mu > 0), on dimensionless arguments x, y:
     *
     * - min: (x + y - sqrt((x - y)^2 + 4 mu^2)) / 2 (Chen-Harker-Kanzow-Smale);
     * - Fischer-Burmeister: sqrt(x^2 + y^2 + 2 mu^2) - x - y (Kanzow).
     *
     * Both are smooth, tend to C as mu -> 0 (|C_mu - C| <= mu), and vanish
     * exactly on the central path x > 0, y > 0, x y = mu^2, so that the
     * smoothed system has a unique solution that tends to the solution of
     * the inequality. This is the homotopy of the continuation with which
     * SemismoothNewton recovers from a stalled active set.
     */
    double
    smoothed_value(const double x, const double y, const double mu) const;

    /// The gradient (dC_mu/dx, dC_mu/dy) of smoothed_value().
    std::array<double, 2>
    smoothed_gradient(const double x, const double y, const double mu) const;
  };
} // namespace VI
