#include <deal.II/lac/trilinos_vector.h>

#include <vi/mesh_sequence.h>

namespace VI
{
  using namespace dealii;


  template <int dim>
  void
  flag_all_cells(parallel::distributed::Triangulation<dim> &mesh)
  {
    for (const auto &cell : mesh.active_cell_iterators())
      if (cell->is_locally_owned())
        cell->set_refine_flag();
  }


  template <int dim, typename VectorType>
  std::unique_ptr<parallel::distributed::SolutionTransfer<dim, VectorType>>
  refine_flagged_cells(parallel::distributed::Triangulation<dim> &mesh,
                       const DoFHandler<dim>                     &dof_handler,
                       std::initializer_list<const VectorType *>  fields,
                       const bool                                 carry)
  {
    mesh.prepare_coarsening_and_refinement();
    std::unique_ptr<parallel::distributed::SolutionTransfer<dim, VectorType>>
      transfer;
    if (carry)
      {
        transfer = std::make_unique<
          parallel::distributed::SolutionTransfer<dim, VectorType>>(
          dof_handler);
        transfer->prepare_for_coarsening_and_refinement(
          std::vector<const VectorType *>(fields));
      }
    mesh.execute_coarsening_and_refinement();
    return transfer;
  }


  template <int dim, typename VectorType>
  void
  interpolate_carried(
    std::unique_ptr<parallel::distributed::SolutionTransfer<dim, VectorType>>
                                       &transfer,
    std::initializer_list<VectorType *> fields)
  {
    std::vector<VectorType *> into(fields);
    transfer->interpolate(into);
    transfer.reset();
  }


  template void
  flag_all_cells(parallel::distributed::Triangulation<2> &);
  template std::unique_ptr<
    parallel::distributed::SolutionTransfer<2, TrilinosWrappers::MPI::Vector>>
  refine_flagged_cells(
    parallel::distributed::Triangulation<2> &,
    const DoFHandler<2> &,
    std::initializer_list<const TrilinosWrappers::MPI::Vector *>,
    const bool);
  template void
  interpolate_carried(
    std::unique_ptr<
      parallel::distributed::SolutionTransfer<2, TrilinosWrappers::MPI::Vector>>
      &,
    std::initializer_list<TrilinosWrappers::MPI::Vector *>);
} // namespace VI
