// Marking of cells for refinement (VI::mark_cells_for_refinement).
#include <deal.II/distributed/tria.h>
#include <deal.II/grid/grid_generator.h>
#include <deal.II/lac/vector.h>

#include <vi/marking.h>
#include <vi/parameters.h>

#include <gtest/gtest.h>

namespace
{
  // The number of cells marked on a 4 x 4 mesh of the unit square whose
  // indicators are equal on the orbits of the square's symmetry group:
  // the 8 cells along the edges (not the corners) carry the largest.
  unsigned int
  n_marked(const VI::Marking marking, const double fraction)
  {
    dealii::parallel::distributed::Triangulation<2> tria(MPI_COMM_WORLD);
    dealii::GridGenerator::hyper_cube(tria);
    tria.refine_global(2);
    dealii::Vector<double> indicators(tria.n_active_cells());
    for (const auto &cell : tria.active_cell_iterators())
      {
        const auto c      = cell->center();
        const bool edge_x = c[0] < 0.25 || c[0] > 0.75;
        const bool edge_y = c[1] < 0.25 || c[1] > 0.75;
        // (the squared indicators of seed-jump, Q2, on this mesh, equal to
        // round-off as computed, in the order of the cells)
        static const double largest[] = {0.00012432564678468652,
                                         0.00012432564678468646,
                                         0.00012432564678468641,
                                         0.00012432564678468636,
                                         0.00012432564678468649,
                                         0.00012432564678468644,
                                         0.00012432564678468646,
                                         0.00012432564678468644};
        static unsigned int n_largest = 0;
        const unsigned int  k         = cell->active_cell_index();
        indicators(k) = (edge_x && edge_y) ? 4.1610970755015682e-05 :
                        (edge_x || edge_y) ? largest[n_largest++ % 8] :
                                             7.4148937382112736e-05;
      }
    VI::mark_cells_for_refinement(tria, indicators, marking, fraction);
    unsigned int n = 0;
    for (const auto &cell : tria.active_cell_iterators())
      if (cell->refine_flag_set())
        {
          ++n;
          const auto c = cell->center();
          EXPECT_TRUE((c[0] < 0.25 || c[0] > 0.75) !=
                      (c[1] < 0.25 || c[1] > 0.75))
            << "marked a cell that is not among the largest, at " << c;
        }
    return n;
  }
} // namespace


// A threshold inside the group of the largest indicators refines the whole
// group: GridRefinement's threshold alone marks none of them, or some,
// chosen by the last digits of the indicators (then an adaptive loop
// would solve on the same mesh again, or its meshes would follow
// round-off).
TEST(Marking, TiesAtTheThresholdRefineTheWholeGroup)
{
  EXPECT_EQ(n_marked(VI::Marking::fixed_fraction, 0.3), 8u);
  EXPECT_EQ(n_marked(VI::Marking::fixed_fraction, 0.2), 8u);
  // (Dorfler's set of least cardinality has 4 of the 8: 0.3 of the sum)
  EXPECT_EQ(n_marked(VI::Marking::dorfler, 0.3), 8u);
  EXPECT_EQ(n_marked(VI::Marking::dorfler, 0.1), 8u);
}


// The next mesh of a sequence: every cell for global refinement (no
// indicators needed), the marked ones for adaptive refinement, which
// without indicators is an error rather than a silent uniform step.
TEST(Marking, NextMeshIsUniformOrMarked)
{
  dealii::parallel::distributed::Triangulation<2> tria(MPI_COMM_WORLD);
  dealii::GridGenerator::hyper_cube(tria);
  tria.refine_global(2);
  const auto n_flagged = [&]() {
    unsigned int n = 0;
    for (const auto &cell : tria.active_cell_iterators())
      {
        n += cell->refine_flag_set() ? 1 : 0;
        cell->clear_refine_flag();
      }
    return n;
  };
  VI::MeshParameters mesh;
  mesh.refinement = VI::Refinement::global;
  VI::flag_next_mesh(tria, mesh, nullptr);
  EXPECT_EQ(n_flagged(), 16u);

  mesh.refinement          = VI::Refinement::adaptive;
  mesh.marking             = VI::Marking::fixed_fraction;
  mesh.refinement_fraction = 0.25;
  dealii::Vector<double> indicators(tria.n_active_cells());
  for (unsigned int k = 0; k < indicators.size(); ++k)
    indicators(k) = 1. + k; // (distinct: the 4 largest are marked)
  VI::flag_next_mesh(tria, mesh, &indicators);
  EXPECT_EQ(n_flagged(), 4u);
  EXPECT_ANY_THROW(VI::flag_next_mesh(tria, mesh, nullptr));
}
