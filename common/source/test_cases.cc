#include <deal.II/base/mpi.h>
#include <deal.II/base/quadrature.h>
#include <deal.II/base/utilities.h>
#include <deal.II/fe/fe.h>
#include <deal.II/fe/mapping.h>
#include <deal.II/grid/tria.h>

#include <vi/errors.h>
#include <vi/expression_function.h>
#include <vi/test_cases.h>

#include <array>
#include <cmath>
#include <functional>
#include <map>
#include <sstream>
#include <tuple>

namespace VI
{
  using namespace dealii;

  namespace
  {
    /**
     * phi(|x - center|), with gradient phi'(r) (x - center) / r. The seed's
     * data are all of this form.
     */
    template <int dim>
    class RadialFunction : public Function<dim>
    {
    public:
      RadialFunction(const Point<dim>                   &center,
                     const std::function<double(double)> phi,
                     const std::function<double(double)> dphi = {})
          : center(center)
          , phi(phi)
          , dphi(dphi)
      {
      }

      double
      value(const Point<dim> &p, const unsigned int = 0) const override
      {
        return phi(p.distance(center));
      }

      Tensor<1, dim>
      gradient(const Point<dim> &p, const unsigned int = 0) const override
      {
        Assert(dphi, ExcMessage("This radial function has no gradient."));
        const double r = p.distance(center);
        if (r == 0.)
          return Tensor<1, dim>();
        return dphi(r) / r * (p - center);
      }

    private:
      const Point<dim>                    center;
      const std::function<double(double)> phi, dphi;
    };


    template <int dim>
    std::shared_ptr<const Function<dim>>
    radial(const Point<dim>                   &center,
           const std::function<double(double)> phi,
           const std::function<double(double)> dphi = {})
    {
      return std::make_shared<RadialFunction<dim>>(center, phi, dphi);
    }


    /*
     * Seed test 1: u1 = -u2 = s^N outside the contact disk r < R, s = r^2 -
     * R^2, and lambda = 1000 r^3 (R^2 - r^2)^3 inside. With
     * -Lap s^N = -4 N s^(N-2) (N r^2 - R^2), the forces follow from the
     * equations: f1 = -mu1 Lap u1 - lambda, f2 = -mu2 Lap u2 + lambda.
     */
    template <int dim>
    void
    make_seed_smooth(const Point<dim> &center, MembraneData<dim> &data)
    {
      const double R = 1. / 3., N = 6.;
      const double mu1 = data.mu1, mu2 = data.mu2;

      const auto u = [=](const double r) {
        return r >= R ? std::pow(r * r - R * R, N) : 0.;
      };
      const auto du = [=](const double r) {
        return r >= R ? 2. * N * r * std::pow(r * r - R * R, N - 1) : 0.;
      };
      const auto minus_laplacian_u = [=](const double r) {
        return r >= R ? -4. * N * std::pow(r * r - R * R, N - 2) *
                          (N * r * r - R * R) :
                        0.;
      };
      const auto lambda = [=](const double r) {
        return r < R ? 1000. * std::pow(r, 3) * std::pow(R * R - r * r, 3) : 0.;
      };
      const auto dlambda = [=](const double r) {
        return r < R ?
                 1000. * (3. * r * r * std::pow(R * R - r * r, 3) -
                          6. * std::pow(r, 4) * std::pow(R * R - r * r, 2)) :
                 0.;
      };

      data.exact_u1 = radial<dim>(center, u, du);
      data.exact_u2 = radial<dim>(
        center,
        [=](const double r) { return -u(r); },
        [=](const double r) { return -du(r); });
      data.exact_lambda = radial<dim>(center, lambda, dlambda);
      data.f1           = radial<dim>(center, [=](const double r) {
        return mu1 * minus_laplacian_u(r) - lambda(r);
      });
      data.f2           = radial<dim>(center, [=](const double r) {
        return -mu2 * minus_laplacian_u(r) + lambda(r);
      });
      data.g1           = data.exact_u1;
      data.g2           = data.exact_u2;
    }


    /*
     * Seed test 2: u1 = s^2 for r > R, u2 = 0, lambda = 8 R^2 for r <= R.
     * -Lap s^2 = 8 R^2 - 16 r^2, so f1 = -8 R^2 inside and
     * mu1 (8 R^2 - 16 r^2) outside; f2 = lambda.
     */
    template <int dim>
    void
    make_seed_jump(const Point<dim> &center, MembraneData<dim> &data)
    {
      const double R   = 1. / 3.;
      const double mu1 = data.mu1;

      const auto u = [=](const double r) {
        return r > R ? std::pow(r * r - R * R, 2) : 0.;
      };
      const auto du = [=](const double r) {
        return r > R ? 4. * r * (r * r - R * R) : 0.;
      };
      const auto lambda = [=](const double r) {
        return r <= R ? 8. * R * R : 0.;
      };

      data.exact_u1 = radial<dim>(center, u, du);
      data.exact_u2 = std::make_shared<Functions::ZeroFunction<dim>>();
      data.exact_lambda =
        radial<dim>(center, lambda, [](const double) { return 0.; });
      data.f1 = radial<dim>(center, [=](const double r) {
        return (r > R ? mu1 * (8. * R * R - 16. * r * r) : 0.) - lambda(r);
      });
      data.f2 = radial<dim>(center, lambda);
      data.g1 = data.exact_u1;
      data.g2 = data.exact_u2;
    }


    /// The function of one formula (ExpressionFunction: muparser, and
    /// gradients by fourth-order differences with step 1e-4, accurate to
    /// about 1e-12 relative for smooth functions).
    template <int dim>
    std::shared_ptr<Function<dim>>
    parse_expression(const std::string                   &parameter,
                     const std::string                   &formula,
                     const std::map<std::string, double> &constants,
                     const Point<dim>                    &probe,
                     const bool time_dependent = false)
    {
      try
        {
          return std::make_shared<ExpressionFunction<dim>>(
            formula, constants, probe, time_dependent, /*h=*/1e-4);
        }
      catch (const InputError &error)
        {
          throw InputError("Problem/Expression/" + parameter +
                           ": cannot evaluate <" + formula +
                           ">: " + error.what());
        }
    }
  } // namespace


  std::map<std::string, double>
  parse_expression_constants(const std::string &text)
  {
    std::map<std::string, double> constants = {{"pi", numbers::PI},
                                               {"Pi", numbers::PI}};
    for (const std::string &item : Utilities::split_string_list(text, ','))
      {
        const auto        equal  = item.find('=');
        const std::string name   = Utilities::trim(item.substr(0, equal));
        const std::string value  = equal == std::string::npos ?
                                     "" :
                                     Utilities::trim(item.substr(equal + 1));
        char             *end    = nullptr;
        const double      number = std::strtod(value.c_str(), &end);
        const bool        valid_name =
          !name.empty() && (std::isalpha(name[0]) || name[0] == '_') &&
          name.find_first_not_of("abcdefghijklmnopqrstuvwxyzABCDEFGHIJKLMNOPQ"
                                 "RSTUVWXYZ0123456789_") == std::string::npos;
        if (!valid_name || value.empty() || *end != '\0' ||
            !std::isfinite(number))
          throw InputError("Problem/Expression/Constants: cannot read <" +
                           item +
                           ">; expected name=number pairs separated "
                           "by commas");
        constants[name] = number;
      }
    return constants;
  }


  std::string
  membrane_test_case_names()
  {
    return "seed-smooth|seed-jump|expression";
  }


  void
  check_obstacle_entries(const ProblemParameters                       &problem,
                         const std::vector<std::array<std::string, 3>> &unused)
  {
    const ExpressionParameters &e = problem.expression;
    if (problem.test_case != "expression")
      throw InputError("Problem/Model = obstacle needs Test case = "
                       "expression (the obstacle is Expression/obstacle)");
    if (Utilities::trim(e.obstacle).empty())
      throw InputError("Problem/Expression/obstacle is empty; Model = "
                       "obstacle needs a formula");
    std::vector<std::array<std::string, 3>> entries = {{{"f2", e.f2, "0"}},
                                                       {{"g2", e.g2, "0"}},
                                                       {{"u2", e.u2, ""}}};
    entries.insert(entries.end(), unused.begin(), unused.end());
    for (const auto &[name, value, unset] : entries)
      if (Utilities::trim(value) != unset)
        throw InputError("Problem/Expression/" + name +
                         " is not used with Model = obstacle (membrane 2 is "
                         "the obstacle); remove it");
    if (problem.mu2 != 1.)
      throw InputError("Problem/mu2 is not used with Model = obstacle "
                       "(membrane 2 is the obstacle); remove it");
  }


  // Model = obstacle: membrane 1 over the obstacle, which takes membrane
  // 2's place (fixed to it, with no error of its own).
  template <int dim>
  void
  make_obstacle_data(const ProblemParameters &problem,
                     const Point<dim>        &center,
                     MembraneData<dim>       &data)
  {
    check_obstacle_entries(problem);
    const ExpressionParameters &e = problem.expression;
    data.name += " (obstacle)";
    data.obstacle = parse_expression<dim>(
      "obstacle", e.obstacle, parse_expression_constants(e.constants), center);
    data.g2              = data.obstacle;
    data.smooth_obstacle = problem.smooth_obstacle;
    data.f2              = std::make_shared<Functions::ZeroFunction<dim>>();
    data.mu2             = data.mu1;
    if (data.exact_u1)
      data.exact_u2 = data.obstacle;
  }


  template <int dim>
  MembraneData<dim>
  make_membrane_data(const ProblemParameters &problem, const Point<dim> &center)
  {
    MembraneData<dim> data;
    data.name = problem.test_case;
    data.mu1  = problem.mu1;
    data.mu2  = problem.mu2;

    if (problem.test_case == "seed-smooth")
      make_seed_smooth(center, data);
    else if (problem.test_case == "seed-jump")
      make_seed_jump(center, data);
    else if (problem.test_case == "expression")
      {
        const ExpressionParameters &e = problem.expression;
        const auto constants          = parse_expression_constants(e.constants);
        const auto parse              = [&](const std::string &name,
                               const std::string &formula) {
          return parse_expression<dim>(name, formula, constants, center);
        };
        for (const auto &[name, formula] :
             {std::pair<std::string, std::string>{"f1", e.f1},
              {"f2", e.f2},
              {"g1", e.g1},
              {"g2", e.g2}})
          if (Utilities::trim(formula).empty())
            throw InputError("Problem/Expression/" + name +
                             " is empty; give a formula (e.g. 0)");
        data.f1 = parse("f1", e.f1);
        data.f2 = parse("f2", e.f2);
        data.g1 = parse("g1", e.g1);
        data.g2 = parse("g2", e.g2);

        const bool has_u1 = !Utilities::trim(e.u1).empty();
        const bool has_u2 = !Utilities::trim(e.u2).empty();
        // (over an obstacle, exact u2 is the obstacle)
        if (problem.model == Model::two_membranes && has_u1 != has_u2)
          throw InputError("Problem/Expression: give both exact solutions u1 "
                           "and u2, or neither");
        if (has_u1)
          {
            data.exact_u1 = parse("u1", e.u1);
            if (problem.model == Model::two_membranes)
              data.exact_u2 = parse("u2", e.u2);
          }
        if (!Utilities::trim(e.lambda).empty())
          data.exact_lambda = parse("lambda", e.lambda);
      }
    else
      throw InputError("Problem/Test case: unknown test case <" +
                       problem.test_case +
                       ">; accepted values: " + membrane_test_case_names());
    if (problem.model == Model::obstacle)
      make_obstacle_data(problem, center, data);
    else if (!Utilities::trim(problem.expression.obstacle).empty())
      throw InputError("Problem/Expression/obstacle is given, but Model = "
                       "two-membranes does not use it; set Model = obstacle");
    return data;
  }


  template <int dim>
  std::shared_ptr<Function<dim>>
  parse_expression_function(const std::string &parameter,
                            const std::string &formula,
                            const std::string &constants,
                            const Point<dim>  &probe,
                            const bool         time_dependent)
  {
    return parse_expression<dim>(parameter,
                                 formula,
                                 parse_expression_constants(constants),
                                 probe,
                                 time_dependent);
  }


  template <int dim>
  void
  check_membrane_data(const MembraneData<dim>       &data,
                      const Triangulation<dim, dim> &triangulation,
                      const Domain                  &domain,
                      const Mapping<dim, dim>       &mapping,
                      const std::vector<Point<dim>> &interior_points,
                      const std::vector<Point<dim>> &boundary_points,
                      const MPI_Comm                 comm)
  {
    std::string violation;
    const auto  report = [&](const std::string &message) {
      if (violation.empty())
        violation = message;
    };

    for (const auto &cell : triangulation.active_cell_iterators())
      if (cell->is_locally_owned() && violation.empty())
        {
          for (const auto &unit_point : interior_points)
            {
              const Point<dim> p =
                mapping.transform_unit_to_real_cell(cell, unit_point);
              for (const auto &[name, f] :
                   {std::pair<const char *, const Function<dim> *>{
                      "f1", data.f1.get()},
                    {"f2", data.f2.get()}})
                if (!std::isfinite(f->value(p)))
                  {
                    std::ostringstream message;
                    message << name << " is not finite at (" << p
                            << "): " << f->value(p);
                    report(message.str());
                  }
            }
          // The obstacle is also taken at the nodes.
          if (data.obstacle)
            for (const auto *points : {&interior_points, &boundary_points})
              for (const auto &unit_point : *points)
                {
                  const Point<dim> p =
                    mapping.transform_unit_to_real_cell(cell, unit_point);
                  if (!std::isfinite(data.obstacle->value(p)))
                    {
                      std::ostringstream message;
                      message << "the obstacle is not finite at (" << p
                              << "): " << data.obstacle->value(p);
                      report(message.str());
                    }
                }
          for (const unsigned int f : cell->face_indices())
            if (cell->face(f)->at_boundary() &&
                domain.is_clamped(cell->face(f)->boundary_id()))
              for (const auto &unit_point : boundary_points)
                {
                  // Face 2d + s of the unit cell is {x_d = s}.
                  if (std::abs(unit_point[f / 2] - double(f % 2)) > 1e-12)
                    continue;
                  const Point<dim> p =
                    mapping.transform_unit_to_real_cell(cell, unit_point);
                  const double g1 = data.g1->value(p), g2 = data.g2->value(p);
                  std::ostringstream message;
                  if (!std::isfinite(g1) || !std::isfinite(g2))
                    message << "the boundary data are not finite at (" << p
                            << "): g1 = " << g1 << ", g2 = " << g2;
                  else if (g1 - g2 <
                           -1e-12 * std::max({1., std::abs(g1), std::abs(g2)}))
                    {
                      // (over an obstacle, g2 is the obstacle)
                      const char *lower = data.obstacle ? "obstacle" : "g2";
                      const char *u2    = data.obstacle ? "obstacle" : "u2";
                      message << (data.obstacle ?
                                    "the obstacle is above g1 on the clamped "
                                    "boundary at (" :
                                    "g1 < g2 on the boundary at (")
                              << p << "): g1 = " << g1 << ", " << lower << " = "
                              << g2 << "; the constraint u1 >= " << u2
                              << " cannot hold there";
                    }
                  if (!message.str().empty())
                    report(message.str());
                }
        }
    for (const std::string &message :
         Utilities::MPI::all_gather(comm, violation))
      if (!message.empty())
        throw InputError("Problem: " + message);
  }


  template <int dim>
  void
  check_membrane_data(const MembraneData<dim>       &data,
                      const Triangulation<dim, dim> &triangulation,
                      const Domain                  &domain,
                      const Mapping<dim, dim>       &mapping,
                      const FiniteElement<dim, dim> &fe,
                      const Quadrature<dim>         &quadrature)
  {
    check_membrane_data(data,
                        triangulation,
                        domain,
                        mapping,
                        quadrature.get_points(),
                        fe.get_unit_support_points(),
                        triangulation.get_communicator());
  }


  template void
  check_membrane_data(const MembraneData<2> &,
                      const Triangulation<2, 2> &,
                      const Domain &,
                      const Mapping<2, 2> &,
                      const std::vector<Point<2>> &,
                      const std::vector<Point<2>> &,
                      const MPI_Comm);
  template void
  check_membrane_data(const MembraneData<2> &,
                      const Triangulation<2, 2> &,
                      const Domain &,
                      const Mapping<2, 2> &,
                      const FiniteElement<2, 2> &,
                      const Quadrature<2> &);
  template MembraneData<2>
  make_membrane_data(const ProblemParameters &, const Point<2> &);
  template std::shared_ptr<Function<2>>
  parse_expression_function(const std::string &,
                            const std::string &,
                            const std::string &,
                            const Point<2> &,
                            const bool);
} // namespace VI
