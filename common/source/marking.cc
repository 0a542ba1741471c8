#include <deal.II/distributed/grid_refinement.h>

#include <vi/marking.h>

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
  }


  template void
  mark_cells_for_refinement(parallel::distributed::Triangulation<2> &,
                            const Vector<double> &,
                            const std::string &,
                            const double);
} // namespace VI
