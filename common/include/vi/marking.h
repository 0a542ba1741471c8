#pragma once

#include <deal.II/distributed/tria.h>
#include <deal.II/lac/vector.h>

namespace VI
{
  struct MeshParameters;
  enum class Marking; // (vi/parameters.h)

  /**
   * Marking of cells for refinement from the squared cell indicators
   * eta_K^2 (the cell values of a ContactEstimate), on a distributed mesh
   * (only the entries of locally owned cells are read):
   *
   * - Marking::dorfler (bulk chasing): refine a set M of cells of least
   *   cardinality with sum_{K in M} eta_K^2 >= theta sum_K eta_K^2,
   *   theta = `fraction`;
   * - Marking::fixed_fraction: refine the `fraction` of cells with the largest
   *   indicators.
   *
   * Both set the refinement flags through
   * parallel::distributed::GridRefinement, whose global thresholds make the
   * marking independent of the partition; no coarsening. Their thresholds
   * come from a bisection that can end inside a group of indicators equal
   * to round-off (symmetric meshes: the 8 cells of an orbit of the
   * square's symmetry group) and then mark some of them, chosen by their
   * last digits, or none. Such a group is marked whole: every cell whose
   * indicator is within a relative 1e-10 of the least marked one is
   * marked, and when no cell is marked, those within 1e-10 of the largest
   * (so that an adaptive loop never solves on the same mesh again). The
   * marked set only grows, so the criterion still holds.
   */
  template <int dim>
  void
  mark_cells_for_refinement(
    dealii::parallel::distributed::Triangulation<dim> &triangulation,
    const dealii::Vector<double>                      &squared_indicators,
    const Marking                                      marking,
    const double                                       fraction);


  /**
   * Flag the cells of the next mesh of a sequence: with `Mesh/Refinement =
   * adaptive` those mark_cells_for_refinement() chooses from the squared
   * cell indicators (which must be given) with the mesh's marking and
   * fraction, otherwise every cell (uniform refinement; the indicators, if
   * any, are not read).
   */
  template <int dim>
  void
  flag_next_mesh(
    dealii::parallel::distributed::Triangulation<dim> &triangulation,
    const MeshParameters                              &mesh,
    const dealii::Vector<double>                      *squared_indicators);
} // namespace VI
