#include <deal.II/fe/mapping_q.h>
#include <deal.II/grid/grid_generator.h>
#include <deal.II/grid/grid_tools.h>
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
    if (name == "square-circle")
      return Geometry::square_circle;
    throw InputError("Mesh/Geometry: unknown geometry <" + name +
                     ">; accepted values: square|disk|L-shape|square-circle");
  }


  bool
  has_curved_cells(const Geometry geometry)
  {
    return geometry == Geometry::disk || geometry == Geometry::square_circle;
  }


  namespace
  {
    // The unit square with the circle |x - c| = R, c = (0.5, 0.5), R = 1/3,
    // as cell faces: the twelve-cell disk of radius R inside, the eight-cell
    // square with a hole of radius R outside (their eight vertices on the
    // circle coincide), shifted to c. The faces on the circle follow a
    // spherical manifold (id 0), and every cell a transfinite interpolation
    // of its faces (id 1), which keeps the cells next to the circle regular
    // under refinement on both sides; the boundary of the square is flat.
    template <int dim>
    void
    make_square_circle(Triangulation<dim> &tria)
    {
      static_assert(dim == 2, "square-circle is a two-dimensional domain");
      const double       R = 1. / 3.;
      const Point<dim>   c(0.5, 0.5);
      Triangulation<dim> disk, plate;
      GridGenerator::hyper_ball_balanced(disk, Point<dim>(), R);
      GridGenerator::hyper_cube_with_cylindrical_hole(plate, R, 0.5);
      GridGenerator::merge_triangulations(disk, plate, tria, 1e-12);
      AssertThrow(tria.n_vertices() ==
                    disk.n_vertices() + plate.n_vertices() - 8,
                  ExcInternalError("square-circle: the disk and the square "
                                   "with a hole do not share the eight "
                                   "vertices of their circle"));
      GridTools::shift(c, tria);

      tria.set_all_manifold_ids(1);
      for (const auto &cell : tria.active_cell_iterators())
        for (const unsigned int f : cell->face_indices())
          {
            const auto face = cell->face(f);
            if (face->at_boundary())
              face->set_manifold_id(numbers::flat_manifold_id);
            else if (std::abs(face->vertex(0).distance(c) - R) < 1e-12 &&
                     std::abs(face->vertex(1).distance(c) - R) < 1e-12)
              face->set_manifold_id(0);
          }
      tria.set_manifold(0, SphericalManifold<dim>(c));
      TransfiniteInterpolationManifold<dim> inside;
      inside.initialize(tria);
      tria.set_manifold(1, inside);
    }
  } // namespace


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
        case Geometry::square_circle:
          make_square_circle(tria);
          break;
      }
  }


  template <int dim>
  Point<dim>
  geometry_center(const Geometry geometry)
  {
    Point<dim> center;
    if (geometry == Geometry::square || geometry == Geometry::square_circle)
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
        case Geometry::square_circle:
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
        case Geometry::square_circle:
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
      has_curved_cells(geometry) ? std::max(1u, fe_degree) : 1u);
  }


  template void
  make_coarse_mesh(const Geometry, Triangulation<2> &);
  template Point<2>
  geometry_center(const Geometry);
  template std::unique_ptr<Mapping<2>>
  make_mapping(const Geometry, const unsigned int);
} // namespace VI
