#include <vi/cell_function_values.h>

namespace VI
{
  using namespace dealii;

  template <int dim>
  void
  cell_function_values(
    const FEValuesBase<dim>                              &fe_values,
    const typename DoFHandler<dim>::active_cell_iterator &cell,
    const TrilinosWrappers::MPI::Vector                  &vector,
    std::vector<double>                                  &coefficients,
    std::vector<double>                                  *values,
    std::vector<Tensor<1, dim>>                          *gradients)
  {
    Assert(fe_values.get_fe().n_components() == 1,
           ExcMessage("cell_function_values: the element must be scalar."));
    AssertDimension(cell->get_fe().n_dofs_per_cell(), fe_values.dofs_per_cell);
    coefficients.resize(fe_values.dofs_per_cell);
    cell->get_dof_values(vector, coefficients.begin(), coefficients.end());
    const FEValuesViews::Scalar<dim> &scalar =
      fe_values[FEValuesExtractors::Scalar(0)];
    if (values)
      scalar.get_function_values_from_local_dof_values(coefficients, *values);
    if (gradients)
      scalar.get_function_gradients_from_local_dof_values(coefficients,
                                                          *gradients);
  }


  template void
  cell_function_values<2>(const FEValuesBase<2> &,
                          const DoFHandler<2>::active_cell_iterator &,
                          const TrilinosWrappers::MPI::Vector &,
                          std::vector<double> &,
                          std::vector<double> *,
                          std::vector<Tensor<1, 2>> *);
} // namespace VI
