#include <deal.II/fe/mapping_q.h>
#include <deal.II/grid/grid_generator.h>
#include <deal.II/grid/manifold_lib.h>

#include <vi/errors.h>
#include <vi/geometry.h>

#include <cmath>

namespace VI
{
  using namespace dealii;

  Geometry
  geometry_from_name(const std::string &name)
  {
    if (name == "square")
      return Geometry::square;
    if (name == "disk")
      return Geometry::disk;
    if (name == "L-shape")
      return Geometry::L_shape;
    throw InputError("Mesh/Geometry: unknown geometry <" + name +
                     ">; accepted values: square|disk|L-shape");
  }


  template <int dim>
  void
  make_coarse_mesh(const Geometry geometry, Triangulation<dim> &tria)
  {
    switch (geometry)
      {
        case Geometry::square:
          GridGenerator::hyper_cube(tria, 0., 1.);
          break;
        case Geometry::disk:
          // Twelve cells: the boundary cells are less distorted than with
          // the five-cell hyper_ball.
          GridGenerator::hyper_ball_balanced(tria, Point<dim>(), 1.);
          break;
        case Geometry::L_shape:
          GridGenerator::hyper_L(tria, -1., 1.);
          break;
      }
  }


  template <int dim>
  Point<dim>
  geometry_center(const Geometry geometry)
  {
    Point<dim> center;
    if (geometry == Geometry::square)
      for (unsigned int d = 0; d < dim; ++d)
        center[d] = 0.5;
    return center;
  }


  double
  geometry_diameter(const Geometry geometry)
  {
    switch (geometry)
      {
        case Geometry::square:
          return std::sqrt(2.);
        case Geometry::disk:
          return 2.;
        case Geometry::L_shape:
          return 2. * std::sqrt(2.);
      }
    return 0.;
  }


  double
  friedrichs_constant(const Geometry geometry)
  {
    switch (geometry)
      {
        case Geometry::square:
          return 1. / std::sqrt(2. * numbers::PI * numbers::PI);
        case Geometry::disk:
          return 1. / std::sqrt(5.7831);
        case Geometry::L_shape:
          return 1. / std::sqrt(9.6397);
      }
    return 0.;
  }


  template <int dim>
  std::unique_ptr<Mapping<dim>>
  make_mapping(const Geometry geometry, const unsigned int fe_degree)
  {
    return std::make_unique<MappingQ<dim>>(
      geometry == Geometry::disk ? std::max(1u, fe_degree) : 1u);
  }


  template void
  make_coarse_mesh(const Geometry, Triangulation<2> &);
  template Point<2>
  geometry_center(const Geometry);
  template std::unique_ptr<Mapping<2>>
  make_mapping(const Geometry, const unsigned int);
} // namespace VI
