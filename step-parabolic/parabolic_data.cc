#include "parabolic_data.h"

#include <deal.II/base/utilities.h>

#include <vi/errors.h>
#include <vi/test_cases.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <regex>

namespace StepParabolic
{
  using namespace dealii;

  template <int dim>
  void
  ParabolicData<dim>::set_time(const double time) const
  {
    for (const auto &function : {f1, f2, g1, g2, exact_u1, exact_u2, obstacle})
      if (function)
        function->set_time(time);
  }


  template <int dim>
  unsigned int
  ring_index(const Point<dim> &p, const Point<dim> &center)
  {
    const double r = p.distance(center);
    return std::min(4u, static_cast<unsigned int>(std::floor(5. * r)));
  }


  namespace
  {
    /// A function of the ring index: constant on each of the five rings.
    template <int dim>
    class RingFunction : public Function<dim>
    {
    public:
      RingFunction(const Point<dim>            &center,
                   const std::array<double, 5> &values)
          : center(center)
          , values(values)
      {
      }

      double
      value(const Point<dim> &p, const unsigned int = 0) const override
      {
        return values[ring_index(p, center)];
      }

    private:
      const Point<dim>            center;
      const std::array<double, 5> values;
    };


    /// Whether a muparser formula uses the variable t.
    bool
    uses_time(const std::string &formula)
    {
      static const std::regex variable_t(
        "(^|[^A-Za-z0-9_.])t([^A-Za-z0-9_]|$)");
      return std::regex_search(formula, variable_t);
    }
  } // namespace


  template <int dim>
  ParabolicData<dim>
  make_parabolic_data(const ProblemParameters &problem,
                      const Point<dim>        &center)
  {
    const bool over_obstacle = problem.model == VI::Model::obstacle;
    if (over_obstacle)
      VI::check_obstacle_entries(problem, {{{"u2_0", problem.u2_0, "0"}}});
    else if (!Utilities::trim(problem.expression.obstacle).empty())
      throw VI::InputError("Problem/Expression/obstacle is set but Problem/"
                           "Model is two-membranes; set Model = obstacle");
    ParabolicData<dim> data;
    data.name = problem.test_case;
    data.mu1  = problem.mu1;
    data.mu2  = problem.mu2;

    if (problem.test_case == "ring")
      {
        const double          g  = 0.05;
        std::array<double, 5> f1 = {{-20., -50., 50., -50., 50.}};
        std::array<double, 5> f2 = {{90., -40., 70., -30., 40.}};
        for (unsigned int k = 0; k < 5; ++k)
          {
            f1[k] *= g;
            f2[k] *= g;
          }
        data.f1         = std::make_shared<RingFunction<dim>>(center, f1);
        data.f2         = std::make_shared<RingFunction<dim>>(center, f2);
        data.g1         = std::make_shared<Functions::ConstantFunction<dim>>(g);
        data.g2         = std::make_shared<Functions::ZeroFunction<dim>>();
        data.initial_u1 = std::make_shared<Functions::ConstantFunction<dim>>(g);
        data.initial_u2 = std::make_shared<Functions::ZeroFunction<dim>>();
      }
    else if (problem.test_case == "expression")
      {
        const VI::ExpressionParameters &e     = problem.expression;
        const auto                      parse = [&](const std::string &name,
                               const std::string &formula,
                               const bool         time_dependent) {
          if (Utilities::trim(formula).empty())
            throw VI::InputError("Problem/Expression/" + name +
                                 " is empty; give a formula (e.g. 0)");
          return VI::parse_expression_function<dim>(
            name, formula, e.constants, center, time_dependent);
        };
        data.f1                       = parse("f1", e.f1, true);
        data.f2                       = parse("f2", e.f2, true);
        data.g1                       = parse("g1", e.g1, true);
        data.g2                       = parse("g2", e.g2, true);
        data.initial_u1               = parse("u1_0", problem.u1_0, false);
        data.initial_u2               = parse("u2_0", problem.u2_0, false);
        data.forces_depend_on_time    = uses_time(e.f1) || uses_time(e.f2);
        data.boundary_depends_on_time = uses_time(e.g1) || uses_time(e.g2);

        if (over_obstacle)
          {
            // Membrane 2 is the obstacle: fixed to it, without load. (u2_0
            // is a second copy, kept at t = 0 while the others move.)
            data.name += " (obstacle)";
            data.obstacle   = parse("obstacle", e.obstacle, true);
            data.f2         = std::make_shared<Functions::ZeroFunction<dim>>();
            data.g2         = data.obstacle;
            data.initial_u2 = parse("obstacle", e.obstacle, true);
            data.mu2        = data.mu1;
            data.forces_depend_on_time    = uses_time(e.f1);
            data.boundary_depends_on_time = uses_time(e.g1);
            data.obstacle_depends_on_time = uses_time(e.obstacle);
            if (!Utilities::trim(e.u1).empty())
              {
                data.exact_u1 = parse("u1", e.u1, true);
                data.exact_u2 = data.obstacle;
              }
            data.set_time(0.);
            return data;
          }
        const bool has_u1 = !Utilities::trim(e.u1).empty();
        const bool has_u2 = !Utilities::trim(e.u2).empty();
        if (has_u1 != has_u2)
          throw VI::InputError("Problem/Expression: give both exact solutions "
                               "u1 and u2, or neither");
        if (has_u1)
          {
            data.exact_u1 = parse("u1", e.u1, true);
            data.exact_u2 = parse("u2", e.u2, true);
          }
      }
    else
      throw VI::InputError("Problem/Test case: unknown test case <" +
                           problem.test_case +
                           ">; accepted values: ring|expression");
    data.set_time(0.);
    return data;
  }


  template struct ParabolicData<2>;
  template ParabolicData<2>
  make_parabolic_data(const ProblemParameters &, const Point<2> &);
  template unsigned int
  ring_index(const Point<2> &, const Point<2> &);
} // namespace StepParabolic
