#pragma once

#include <deal.II/base/function.h>
#include <deal.II/base/point.h>

#include <vi/domain.h>
#include <vi/parameters.h>

#include <array>
#include <map>
#include <memory>
#include <mpi.h>
#include <string>
#include <vector>

namespace dealii
{
  template <int dim, int spacedim>
  class Triangulation;
  template <int dim, int spacedim>
  class Mapping;
  template <int dim, int spacedim>
  class FiniteElement;
  template <int dim>
  class Quadrature;
} // namespace dealii

namespace VI
{
  /**
   * Data of the two-membrane contact problem
   *
   *   -mu1 Lap u1 - lambda = f1,  -mu2 Lap u2 + lambda = f2,
   *   u1 - u2 >= 0,  lambda >= 0,  (u1 - u2) lambda = 0,
   *   u1 = g1, u2 = g2 on the boundary,
   *
   * and its exact solution where one is known (null pointers otherwise).
   */
  template <int dim>
  struct MembraneData
  {
    std::string name;
    double      mu1 = 1.;
    double      mu2 = 1.;

    std::shared_ptr<const dealii::Function<dim>> f1, f2, g1, g2;
    std::shared_ptr<const dealii::Function<dim>> exact_u1, exact_u2,
      exact_lambda;
    /// With Model = obstacle: the rigid obstacle, which then also stands in
    /// for membrane 2 (g2 = exact u2 = obstacle, f2 = 0, mu2 = mu1: u2 is
    /// fixed to it, and only membrane 1 has an error).
    std::shared_ptr<const dealii::Function<dim>> obstacle;
    /// Problem/Smooth obstacle.
    bool smooth_obstacle = false;

    bool
    has_exact_solution() const
    {
      return exact_u1 && exact_u2;
    }
  };


  /// The names accepted for "Problem/Test case" by the steady programs.
  std::string
  membrane_test_case_names();


  /**
   * Build the data of "Problem/Test case":
   * - seed-smooth: u1 = -u2 = (r^2 - R^2)^6 for r >= R, 0 inside, lambda =
   *   1000 r^3 (R^2 - r^2)^3 inside (R = 1/3): smooth, contact on a disk;
   * - seed-jump: u1 = (r^2 - R^2)^2 for r > R, u2 = 0, lambda = 8 R^2
   *   inside: the multiplier jumps across r = R, u1 is only H^{5/2-eps};
   * - expression: muparser formulas of Problem/Expression; with Model =
   *   obstacle, membrane 1 over Problem/Expression/obstacle.
   * r is the distance to `center` (the centre of the domain). The seed's
   * forces are those of mu1 = mu2 = 1; here they are built for the given
   * tensions, so the exact solution holds for any mu1, mu2 > 0.
   * Expressions are parsed and evaluated once at `center`: a malformed
   * formula or an undefined name throws InputError naming the parameter.
   */
  template <int dim>
  MembraneData<dim>
  make_membrane_data(const ProblemParameters  &problem,
                     const dealii::Point<dim> &center);


  /**
   * Model = obstacle: check that the run can take it (Test case =
   * expression with a formula in Expression/obstacle) and that membrane 2's
   * entries f2, g2, u2, mu2 and the program's `unused` ones ({name, value,
   * default}, e.g. step-parabolic's u2_0) are left as they are: a value
   * there would be silently unused. Throws InputError naming the entry.
   */
  void
  check_obstacle_entries(
    const ProblemParameters                       &problem,
    const std::vector<std::array<std::string, 3>> &unused = {});


  /**
   * Check on a mesh that the data are finite and admit a solution, before
   * anything is computed: f1 and f2 finite at `interior_points`, g1 and g2
   * finite with g1 >= g2 (otherwise the constraint u1 >= u2 contradicts
   * the boundary condition) at those of `boundary_points` that lie on a
   * boundary face where `domain` clamps the membranes; both lists are points of
   * the unit cell, mapped into every locally owned cell. Throws InputError
   * naming the first violation on any process (collective over `comm`).
   */
  template <int dim>
  void
  check_membrane_data(const MembraneData<dim>               &data,
                      const dealii::Triangulation<dim, dim> &triangulation,
                      const Domain                          &domain,
                      const dealii::Mapping<dim, dim>       &mapping,
                      const std::vector<dealii::Point<dim>> &interior_points,
                      const std::vector<dealii::Point<dim>> &boundary_points,
                      const MPI_Comm                         comm);

  /// The same check at the points of `quadrature` and the support points
  /// of the nodal element `fe` (collective over the mesh's communicator).
  template <int dim>
  void
  check_membrane_data(const MembraneData<dim>               &data,
                      const dealii::Triangulation<dim, dim> &triangulation,
                      const Domain                          &domain,
                      const dealii::Mapping<dim, dim>       &mapping,
                      const dealii::FiniteElement<dim, dim> &fe,
                      const dealii::Quadrature<dim>         &quadrature);


  /**
   * The muparser function of one formula of Problem/Expression (named
   * `parameter` in messages), in the variables x, y and, if
   * `time_dependent`, t (set with Function::set_time()), with pi and the
   * `constants` ("name=value, ..."). Evaluated once at `probe` (at t = 0):
   * a malformed formula or an undefined name throws InputError. Gradients
   * by fourth-order differences (ExpressionFunction).
   */
  /**
   * The named constants of Problem/Expression/Constants ("R=0.5, A=10"),
   * with pi (and Pi) unless redefined. Throws InputError on a malformed
   * item.
   */
  std::map<std::string, double>
  parse_expression_constants(const std::string &constants);


  template <int dim>
  std::shared_ptr<dealii::Function<dim>>
  parse_expression_function(const std::string        &parameter,
                            const std::string        &formula,
                            const std::string        &constants,
                            const dealii::Point<dim> &probe,
                            const bool                time_dependent = false);
} // namespace VI
