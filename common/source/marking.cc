#include <deal.II/base/mpi.h>
#include <deal.II/distributed/grid_refinement.h>

#include <vi/marking.h>
#include <vi/mesh_sequence.h>
#include <vi/parameters.h>

#include <algorithm>
#include <cmath>
#include <limits>

namespace VI
{
  using namespace dealii;

  template <int dim>
  void
  mark_cells_for_refinement(
    parallel::distributed::Triangulation<dim> &triangulation,
    const Vector<double>                      &squared_indicators,
    const Marking                              marking,
    const double                               fraction)
  {
    AssertDimension(squared_indicators.size(), triangulation.n_active_cells());
    if (marking == Marking::dorfler)
      // With the L1 norm of eta_K^2 the "fraction of the error" is the
      // fraction of the squared estimate: Dorfler's criterion.
      parallel::distributed::GridRefinement::refine_and_coarsen_fixed_fraction(
        triangulation, squared_indicators, fraction, 0., VectorTools::L1_norm);
    else
      parallel::distributed::GridRefinement::refine_and_coarsen_fixed_number(
        triangulation, squared_indicators, fraction, 0.);

    // A threshold inside a group of indicators equal to round-off (cells
    // of a symmetry orbit) splits the group by the last digits of the
    // indicators. The whole group is marked instead: the marked set then
    // depends neither on round-off nor on the partition, and it still
    // satisfies the criterion (it only grows). When nothing was marked,
    // the group of the largest indicator is.
    const MPI_Comm comm         = triangulation.get_communicator();
    double         least_marked = std::numeric_limits<double>::infinity();
    double         largest      = 0;
    for (const auto &cell : triangulation.active_cell_iterators())
      if (cell->is_locally_owned())
        {
          const double indicator =
            squared_indicators(cell->active_cell_index());
          if (cell->refine_flag_set())
            least_marked = std::min(least_marked, indicator);
          largest = std::max(largest, indicator);
        }
    least_marked           = Utilities::MPI::min(least_marked, comm);
    const double threshold = std::isfinite(least_marked) ?
                               least_marked :
                               Utilities::MPI::max(largest, comm);
    if (threshold > 0)
      for (const auto &cell : triangulation.active_cell_iterators())
        if (cell->is_locally_owned() &&
            squared_indicators(cell->active_cell_index()) >=
              (1. - 1e-10) * threshold)
          cell->set_refine_flag();
  }


  template <int dim>
  void
  flag_next_mesh(parallel::distributed::Triangulation<dim> &triangulation,
                 const MeshParameters                      &mesh,
                 const Vector<double>                      *squared_indicators)
  {
    if (mesh.refinement == Refinement::adaptive)
      {
        AssertThrow(squared_indicators,
                    ExcMessage("Adaptive refinement without an estimate"));
        mark_cells_for_refinement(triangulation,
                                  *squared_indicators,
                                  mesh.marking,
                                  mesh.refinement_fraction);
      }
    else
      flag_all_cells(triangulation);
  }


  template void
  flag_next_mesh(parallel::distributed::Triangulation<2> &,
                 const MeshParameters &,
                 const Vector<double> *);
  template void
  mark_cells_for_refinement(parallel::distributed::Triangulation<2> &,
                            const Vector<double> &,
                            const Marking,
                            const double);
} // namespace VI
