// The square-circle mesh: the unit square, with the circle of radius 1/3
// about its centre as a line of cell faces on every refined mesh.
#include <deal.II/base/quadrature_lib.h>
#include <deal.II/fe/fe_q.h>
#include <deal.II/fe/fe_values.h>
#include <deal.II/fe/mapping_q.h>
#include <deal.II/grid/grid_tools.h>
#include <deal.II/grid/tria.h>

#include <vi/errors.h>
#include <vi/geometry.h>

#include <gtest/gtest.h>

#include <cmath>

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
  VI::make_coarse_mesh(VI::Geometry::square_circle, tria);
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
  VI::make_coarse_mesh(VI::Geometry::square_circle, tria);
  tria.refine_global(2);
  const auto mapping = VI::make_mapping<2>(VI::Geometry::square_circle, 2);
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
  EXPECT_TRUE(VI::has_curved_cells(VI::Geometry::square_circle));
  EXPECT_FALSE(VI::has_curved_cells(VI::Geometry::square));
  EXPECT_THROW(VI::geometry_from_name("circle"), VI::InputError);
}
