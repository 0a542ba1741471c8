#include <deal.II/base/function.h>
#include <deal.II/fe/mapping.h>
#include <deal.II/lac/trilinos_vector.h>
#include <deal.II/numerics/vector_tools.h>

#include <vi/mesh_sequence.h>
#include <vi/nodal_fields.h>

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


  template <int dim>
  void
  initial_nodal_iterate(
    std::unique_ptr<parallel::distributed::
                      SolutionTransfer<dim, TrilinosWrappers::MPI::Vector>>
      &transfer,
    const std::function<void(const TrilinosWrappers::MPI::Vector &,
                             TrilinosWrappers::MPI::Vector &)>
                                  &dual_coefficients,
    const Mapping<dim>            &mapping,
    const DoFHandler<dim>         &dof_handler,
    const Function<dim>           *g1,
    const Function<dim>           *g2,
    TrilinosWrappers::MPI::Vector &X)
  {
    using Vector          = TrilinosWrappers::MPI::Vector;
    const IndexSet &nodes = dof_handler.locally_owned_dofs();
    const MPI_Comm  comm  = X.get_mpi_communicator();
    Vector          u1(nodes, comm), u2(nodes, comm), lambda(nodes, comm),
      X3(nodes, comm);
    X = 0;
    if (transfer)
      {
        interpolate_carried(transfer, {&u1, &u2, &lambda});
        dual_coefficients(lambda, X3);
        NodalFields::insert(X3, NodalFields::multiplier, X);
      }
    else if (g1 != nullptr && g2 != nullptr)
      {
        VectorTools::interpolate(mapping, dof_handler, *g1, u1);
        VectorTools::interpolate(mapping, dof_handler, *g2, u2);
      }
    NodalFields::insert_displacements(u1, u2, X);
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
  template void
  initial_nodal_iterate(
    std::unique_ptr<
      parallel::distributed::SolutionTransfer<2, TrilinosWrappers::MPI::Vector>>
      &,
    const std::function<void(const TrilinosWrappers::MPI::Vector &,
                             TrilinosWrappers::MPI::Vector &)> &,
    const Mapping<2> &,
    const DoFHandler<2> &,
    const Function<2> *,
    const Function<2> *,
    TrilinosWrappers::MPI::Vector &);
} // namespace VI
