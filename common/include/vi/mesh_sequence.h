#pragma once

#include <deal.II/base/function.h>
#include <deal.II/distributed/solution_transfer.h>
#include <deal.II/distributed/tria.h>
#include <deal.II/dofs/dof_handler.h>
#include <deal.II/fe/mapping.h>
#include <deal.II/lac/trilinos_vector.h>

#include <functional>
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

  /**
   * The first iterate X = (X1, X2, X3) of a nodal discretisation on a new
   * mesh: the fields u1, u2, lambda carried by `transfer` (nested
   * iteration; `dual_coefficients` makes X3 from lambda), or else the
   * Dirichlet data g1, g2 interpolated at the nodes (if they are given) or
   * zero, with a zero multiplier.
   */
  template <int dim>
  void
  initial_nodal_iterate(
    std::unique_ptr<dealii::parallel::distributed::SolutionTransfer<
      dim,
      dealii::TrilinosWrappers::MPI::Vector>> &transfer,
    const std::function<void(const dealii::TrilinosWrappers::MPI::Vector &,
                             dealii::TrilinosWrappers::MPI::Vector &)>
                                          &dual_coefficients,
    const dealii::Mapping<dim, dim>       &mapping,
    const dealii::DoFHandler<dim>         &dof_handler,
    const dealii::Function<dim, double>   *g1,
    const dealii::Function<dim, double>   *g2,
    dealii::TrilinosWrappers::MPI::Vector &X);
} // namespace VI
