// The domains: the square-circle mesh (the unit square, with the circle of
// radius 1/3 about its centre as a line of cell faces on every refined
// mesh), the boundary ids of the built-in geometries, and Friedrichs'
// constant with free sides.
#include <deal.II/base/quadrature_lib.h>
#include <deal.II/fe/fe_q.h>
#include <deal.II/fe/fe_values.h>
#include <deal.II/fe/mapping_q.h>
#include <deal.II/grid/grid_tools.h>
#include <deal.II/grid/tria.h>

#include <vi/domain.h>
#include <vi/errors.h>
#include <vi/parameters.h>

#include <gtest/gtest.h>

#include <cmath>
#include <vector>

namespace
{
  constexpr double R = 1. / 3.;

  double
  distance_to_circle(const dealii::Point<2> &x)
  {
    return x.distance(dealii::Point<2>(0.5, 0.5)) - R;
  }
} // namespace


TEST(SquareCircle, NoCellCrossesTheCircle)
{
  dealii::Triangulation<2> tria;
  VI::Domain(VI::Geometry::square_circle).make_coarse_mesh(tria);
  EXPECT_EQ(tria.n_active_cells(), 20u);
  tria.refine_global(3);

  unsigned int n_faces_on_circle = 0;
  for (const auto &cell : tria.active_cell_iterators())
    {
      // Every cell lies on one side: its vertices (and the mapped midpoints
      // of its faces) are not strictly inside and strictly outside.
      bool inside = false, outside = false;
      for (const unsigned int v : cell->vertex_indices())
        {
          const double d = distance_to_circle(cell->vertex(v));
          inside |= d < -1e-12;
          outside |= d > 1e-12;
        }
      EXPECT_FALSE(inside && outside) << "cell at " << cell->center();
      for (const unsigned int f : cell->face_indices())
        if (std::abs(distance_to_circle(cell->face(f)->vertex(0))) < 1e-12 &&
            std::abs(distance_to_circle(cell->face(f)->vertex(1))) < 1e-12)
          {
            ++n_faces_on_circle;
            // the refined faces follow the circle, not its chords
            EXPECT_NEAR(distance_to_circle(cell->face(f)->center(true)),
                        0.,
                        1e-12);
          }
    }
  // 8 coarse faces, 2^3 children each, seen from both sides
  EXPECT_EQ(n_faces_on_circle, 2u * 8u * 8u);
}


TEST(SquareCircle, CurvedCellsFillTheSquareAndTheDisk)
{
  dealii::Triangulation<2> tria;
  VI::Domain(VI::Geometry::square_circle).make_coarse_mesh(tria);
  tria.refine_global(2);
  const auto mapping =
    VI::Domain(VI::Geometry::square_circle).make_mapping<2>(2);
  ASSERT_EQ(dynamic_cast<const dealii::MappingQ<2> &>(*mapping).get_degree(),
            2u);

  // The areas of the square and of the disk inside the circle, with the Q2
  // mapping and, for comparison, with straight cells (chords of the
  // circle).
  const auto areas = [&](const dealii::Mapping<2> &m) {
    dealii::FE_Q<2>           fe(1);
    dealii::FEValues<2>       values(m,
                               fe,
                               dealii::QGauss<2>(4),
                               dealii::update_JxW_values);
    std::pair<double, double> total_disk{0., 0.};
    for (const auto &cell : tria.active_cell_iterators())
      {
        values.reinit(cell);
        double area = 0;
        for (const double dx : values.get_JxW_values())
          area += dx;
        total_disk.first += area;
        if (distance_to_circle(cell->center()) < 0)
          total_disk.second += area;
      }
    return total_disk;
  };
  const double disk             = dealii::numbers::PI * R * R;
  const auto [total, curved]    = areas(*mapping);
  const auto [total_q1, chords] = areas(dealii::MappingQ<2>(1));
  EXPECT_NEAR(total, 1., 1e-12);
  EXPECT_NEAR(total_q1, 1., 1e-12);
  EXPECT_LT(std::abs(curved - disk), 1e-5 * disk);
  EXPECT_LT(std::abs(curved - disk), 1e-2 * std::abs(chords - disk));
}


TEST(SquareCircle, IsNamedInTheParameters)
{
  EXPECT_EQ(VI::geometry_from_name("square-circle"),
            VI::Geometry::square_circle);
  EXPECT_TRUE(VI::Domain(VI::Geometry::square_circle).has_curved_cells());
  EXPECT_FALSE(VI::Domain(VI::Geometry::square).has_curved_cells());
  EXPECT_THROW(VI::geometry_from_name("circle"), VI::InputError);
}


// The boundary ids of the built-in geometries are those doc/step-membranes.md
// lists (GridGenerator's colours): the square's sides 0, 1 at x = 0, 1 and
// 2, 3 at y = 0, 1; the L-shape's from x = -1 counterclockwise.
TEST(Domain, BuiltInGeometriesNumberTheirSides)
{
  const auto id_at = [](const VI::Geometry      geometry,
                        const dealii::Point<2> &x) {
    dealii::Triangulation<2> tria;
    VI::Domain(geometry).make_coarse_mesh(tria);
    for (const auto &cell : tria.active_cell_iterators())
      for (const unsigned int f : cell->face_indices())
        if (cell->face(f)->at_boundary())
          {
            // x on the (straight) face: |x - a| + |x - b| = |a - b|
            const dealii::Point<2> a = cell->face(f)->vertex(0),
                                   b = cell->face(f)->vertex(1);
            if (std::abs(x.distance(a) + x.distance(b) - a.distance(b)) < 1e-12)
              return int(cell->face(f)->boundary_id());
          }
    return -1;
  };
  using G = VI::Geometry;
  for (const G square : {G::square, G::square_circle})
    {
      EXPECT_EQ(id_at(square, {0., 0.5}), 0);
      EXPECT_EQ(id_at(square, {1., 0.5}), 1);
      EXPECT_EQ(id_at(square, {0.5, 0.}), 2);
      EXPECT_EQ(id_at(square, {0.5, 1.}), 3);
    }
  // hyper_L's coarse faces have length 1
  EXPECT_EQ(id_at(G::L_shape, {-1., -0.5}), 0);
  EXPECT_EQ(id_at(G::L_shape, {-0.5, -1.}), 1);
  EXPECT_EQ(id_at(G::L_shape, {1., -0.5}), 2);
  EXPECT_EQ(id_at(G::L_shape, {0.5, 0.}), 3);
  EXPECT_EQ(id_at(G::L_shape, {0., 0.5}), 4);
  EXPECT_EQ(id_at(G::L_shape, {-0.5, 1.}), 5);
}


// Friedrichs' constant of the square clamped on some sides: the first
// eigenvalue pi^2 / 4 (one side) per clamped direction, pi^2 with both
// sides; the whole boundary gives 2 pi^2 (rounded up by 1e-4 relative).
TEST(Domain, FriedrichsConstantOfTheSquareWithFreeSides)
{
  VI::DomainParameters mesh;
  mesh.geometry = "square";
  const auto constant =
    [&](const std::vector<dealii::types::boundary_id> &ids) {
      VI::BoundaryParameters boundary;
      boundary.clamped_everywhere = false;
      boundary.dirichlet_ids      = ids;
      return VI::Domain(mesh, boundary).friedrichs_constant();
    };
  const double pi = dealii::numbers::PI;
  EXPECT_NEAR(constant({0}), 2. / pi, 1e-3);
  EXPECT_NEAR(constant({0, 2}), std::sqrt(2.) / pi, 1e-3);
  EXPECT_NEAR(constant({0, 1}), 1. / pi, 1e-3);
  EXPECT_NEAR(constant({0, 1, 2}), 1. / std::sqrt(1.25) / pi, 1e-3);
  EXPECT_GE(constant({0, 1, 2}), 1. / std::sqrt(1.25) / pi);
  EXPECT_NEAR(constant({0, 1, 2, 3}), 1. / std::sqrt(2.) / pi, 1e-12);
  VI::BoundaryParameters nowhere;
  nowhere.clamped_everywhere = false;
  EXPECT_THROW(VI::Domain(mesh, nowhere), VI::InputError);
  EXPECT_THROW(constant({4}), VI::InputError);
}
