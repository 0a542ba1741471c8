#include <deal.II/base/mpi.h>
#include <deal.II/distributed/grid_refinement.h>

#include <vi/marking.h>

#include <algorithm>

namespace VI
{
  using namespace dealii;

  template <int dim>
  void
  mark_cells_for_refinement(
    parallel::distributed::Triangulation<dim> &triangulation,
    const Vector<double>                      &squared_indicators,
    const std::string                         &strategy,
    const double                               fraction)
  {
    AssertDimension(squared_indicators.size(), triangulation.n_active_cells());
    if (strategy == "dorfler")
      // With the L1 norm of eta_K^2 the "fraction of the error" is the
      // fraction of the squared estimate: Dorfler's criterion.
      parallel::distributed::GridRefinement::refine_and_coarsen_fixed_fraction(
        triangulation, squared_indicators, fraction, 0., VectorTools::L1_norm);
    else if (strategy == "fixed-fraction")
      parallel::distributed::GridRefinement::refine_and_coarsen_fixed_number(
        triangulation, squared_indicators, fraction, 0.);
    else
      AssertThrow(false,
                  ExcMessage("Unknown marking strategy \"" + strategy + "\""));

    unsigned int n_marked = 0;
    double       largest  = 0;
    for (const auto &cell : triangulation.active_cell_iterators())
      if (cell->is_locally_owned())
        {
          n_marked += cell->refine_flag_set() ? 1 : 0;
          largest =
            std::max(largest, squared_indicators(cell->active_cell_index()));
        }
    const MPI_Comm comm = triangulation.get_communicator();
    if (Utilities::MPI::sum(n_marked, comm) > 0)
      return;
    largest = Utilities::MPI::max(largest, comm);
    if (largest > 0)
      for (const auto &cell : triangulation.active_cell_iterators())
        if (cell->is_locally_owned() &&
            squared_indicators(cell->active_cell_index()) >=
              (1. - 1e-10) * largest)
          cell->set_refine_flag();
  }


  template void
  mark_cells_for_refinement(parallel::distributed::Triangulation<2> &,
                            const Vector<double> &,
                            const std::string &,
                            const double);
} // namespace VI
