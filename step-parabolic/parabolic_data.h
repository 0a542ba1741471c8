#pragma once

#include <deal.II/base/function.h>
#include <deal.II/base/point.h>

#include "parabolic_parameters.h"

#include <memory>
#include <string>

namespace StepParabolic
{
  /**
   * Data of the time-dependent two-membrane problem
   *
   *   d_t u1 - mu1 Lap u1 - lambda = f1,   d_t u2 - mu2 Lap u2 + lambda = f2,
   *   u1 - u2 >= 0,  lambda >= 0,  (u1 - u2) lambda = 0   in Omega x (0, T),
   *   u_alpha = g_alpha on the boundary,  u(0) = u^0 with u1^0 >= u2^0,
   *
   * and its exact solution where one is known (null pointers otherwise).
   * Functions of time are advanced with set_time().
   */
  template <int dim>
  struct ParabolicData
  {
    std::string name;
    double      mu1 = 1., mu2 = 1.;

    std::shared_ptr<dealii::Function<dim>> f1, f2, g1, g2;
    std::shared_ptr<dealii::Function<dim>> initial_u1, initial_u2;
    std::shared_ptr<dealii::Function<dim>> exact_u1, exact_u2;
    /// With Model = obstacle: the rigid obstacle psi(x, y, t) under membrane
    /// 1, which also stands in for membrane 2 (g2 = exact u2 = psi, u2_0 =
    /// psi(0), f2 = 0, mu2 = mu1: u2 is fixed to I_h psi(t_n) at every step,
    /// and only membrane 1 has an error); null for two membranes.
    std::shared_ptr<dealii::Function<dim>> obstacle;
    /// Whether the forces, the boundary data and the obstacle depend on t.
    bool forces_depend_on_time    = false;
    bool boundary_depends_on_time = false;
    bool obstacle_depends_on_time = false;

    bool
    has_exact_solution() const
    {
      return exact_u1 && exact_u2;
    }

    /// Set the time of f, g and the exact solution.
    void
    set_time(const double time) const;
  };


  /**
   * "Problem/Test case":
   * - ring: the test of [DMV20p] on the unit disk: mu1 = mu2 = 1 (unless
   *   set otherwise), g1 = g = 0.05, g2 = 0, u^0 = (g, 0), forces constant in
   *   time and on the rings r in [0,1/5), [1/5,2/5), ..., [4/5,1]:
   *   f1 = (-20, -50, 50, -50, 50) g, f2 = (90, -40, 70, -30, 40) g;
   * - expression: the formulas of Problem/Expression in x, y, t (initial
   *   data u1_0, u2_0 in x, y); with Model = obstacle, membrane 1 over
   *   Problem/Expression/obstacle (x, y, t).
   * r is measured from `center`. Throws InputError on a malformed formula.
   */
  template <int dim>
  ParabolicData<dim>
  make_parabolic_data(const ProblemParameters  &problem,
                      const dealii::Point<dim> &center);

  /// For the ring test: the ring 0..4 of the point (by r = |p - center|).
  template <int dim>
  unsigned int
  ring_index(const dealii::Point<dim> &p, const dealii::Point<dim> &center);
} // namespace StepParabolic
