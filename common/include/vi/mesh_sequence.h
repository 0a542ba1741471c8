#pragma once

#include <deal.II/distributed/solution_transfer.h>
#include <deal.II/distributed/tria.h>
#include <deal.II/dofs/dof_handler.h>

#include <initializer_list>
#include <memory>
#include <vector>

namespace VI
{
  /// Flag every locally owned cell: the next mesh of uniform refinement.
  template <int dim>
  void
  flag_all_cells(dealii::parallel::distributed::Triangulation<dim> &mesh);

  /**
   * The step from one mesh of a sequence to the next: the flagged cells
   * are refined. With nested iteration (`carry`) the solution's fields, as
   * finite element functions on `dof_handler`, go with them: the returned
   * SolutionTransfer interpolates them once the new mesh's unknowns are
   * distributed. Without it the result is null, and the next solve starts
   * from the initial guess.
   */
  template <int dim, typename VectorType>
  std::unique_ptr<
    dealii::parallel::distributed::SolutionTransfer<dim, VectorType>>
  refine_flagged_cells(dealii::parallel::distributed::Triangulation<dim> &mesh,
                       const dealii::DoFHandler<dim>            &dof_handler,
                       std::initializer_list<const VectorType *> fields,
                       const bool                                carry);

  /**
   * The fields that refine_flagged_cells() carried, interpolated into
   * `fields` (vectors of the new mesh's owned unknowns, in the order they
   * were given there); the transfer is spent.
   */
  template <int dim, typename VectorType>
  void
  interpolate_carried(
    std::unique_ptr<
      dealii::parallel::distributed::SolutionTransfer<dim, VectorType>>
                                       &transfer,
    std::initializer_list<VectorType *> fields);
} // namespace VI
