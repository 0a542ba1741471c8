#pragma once

#include <deal.II/base/tensor.h>
#include <deal.II/dofs/dof_handler.h>
#include <deal.II/fe/fe_values.h>
#include <deal.II/lac/trilinos_vector.h>

#include <vector>

namespace VI
{
  /**
   * The values (if `values` is given) and gradients (if `gradients` is
   * given) at the quadrature points of `fe_values` of the finite element
   * function of the (ghosted) coefficient vector `vector` on the active cell
   * `cell`, which `fe_values` was last reinitialised on. The cell's
   * coefficients are read once, into the scratch `coefficients`.
   *
   * This is what FEValuesBase::get_function_values does, without its cost
   * per call in deal.II 9.4 (a Vector allocated, the coefficients read
   * through get_interpolated_dof_values): the estimators read five to eight
   * functions per cell and evaluation, and that cost was a quarter of an
   * evaluation. The element must be scalar.
   */
  template <int dim>
  void
  cell_function_values(
    const dealii::FEValuesBase<dim>                              &fe_values,
    const typename dealii::DoFHandler<dim>::active_cell_iterator &cell,
    const dealii::TrilinosWrappers::MPI::Vector                  &vector,
    std::vector<double>                                          &coefficients,
    std::vector<double>                                          *values,
    std::vector<dealii::Tensor<1, dim>> *gradients = nullptr);
} // namespace VI
