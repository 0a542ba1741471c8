#include "reference_poisson.h"

#include <deal.II/base/index_set.h>
#include <deal.II/base/timer.h>
#include <deal.II/dofs/dof_tools.h>
#include <deal.II/fe/fe_values.h>
#include <deal.II/grid/filtered_iterator.h>
#include <deal.II/lac/affine_constraints.h>
#include <deal.II/lac/dynamic_sparsity_pattern.h>
#include <deal.II/lac/full_matrix.h>
#include <deal.II/lac/solver_cg.h>
#include <deal.II/lac/solver_control.h>
#include <deal.II/lac/sparsity_tools.h>
#include <deal.II/lac/trilinos_precondition.h>
#include <deal.II/lac/trilinos_sparse_matrix.h>
#include <deal.II/lac/trilinos_vector.h>
#include <deal.II/meshworker/copy_data.h>
#include <deal.II/meshworker/mesh_loop.h>
#include <deal.II/meshworker/scratch_data.h>
#include <deal.II/numerics/vector_tools.h>

#include <vi/errors.h>
#include <vi/linear_solvers.h>

#include <map>
#include <vector>

namespace StepMembranes
{
  using namespace dealii;

  template <int dim>
  PoissonCost
  reference_poisson_solve(const Mapping<dim>            &mapping,
                          const DoFHandler<dim>         &dof_handler,
                          const Quadrature<dim>         &quadrature,
                          const double                   mu,
                          const Function<dim>           &f,
                          const Function<dim>           &g,
                          const MPI_Comm                 comm,
                          TrilinosWrappers::MPI::Vector *solution_out)
  {
    Timer                  timer(comm, /*sync_lap_times=*/true);
    const VI::ProcessUsage usage_at_start = VI::ProcessUsage::now(comm);

    const IndexSet &owned = dof_handler.locally_owned_dofs();
    IndexSet        relevant;
    DoFTools::extract_locally_relevant_dofs(dof_handler, relevant);

    AffineConstraints<double> constraints(relevant);
    DoFTools::make_hanging_node_constraints(dof_handler, constraints);
    std::map<types::boundary_id, const Function<dim> *> boundary_data;
    for (const types::boundary_id id :
         dof_handler.get_triangulation().get_boundary_ids())
      boundary_data[id] = &g;
    VectorTools::interpolate_boundary_values(mapping,
                                             dof_handler,
                                             boundary_data,
                                             constraints);
    constraints.close();

    DynamicSparsityPattern pattern(relevant);
    DoFTools::make_sparsity_pattern(dof_handler, pattern, constraints, false);
    SparsityTools::distribute_sparsity_pattern(pattern, owned, comm, relevant);
    TrilinosWrappers::SparseMatrix matrix;
    matrix.reinit(owned, owned, pattern, comm);
    TrilinosWrappers::MPI::Vector rhs(owned, comm), solution(owned, comm);

    // Assembled as the contact problem assembles (MeshWorker::mesh_loop:
    // the cell integrals on all threads, the additions through the
    // constraints in one; f at all points of a cell in one call),
    // so that threads favour neither side of the comparison.
    using Iterator = typename DoFHandler<dim>::active_cell_iterator;
    using CopyData = MeshWorker::CopyData<1, 1, 1>;
    struct Scratch
    {
      MeshWorker::ScratchData<dim> values;
      std::vector<double>          loads;
    };
    const auto cell_worker =
      [&](const Iterator &cell, Scratch &scratch, CopyData &copy) {
        const FEValues<dim> &fe_values = scratch.values.reinit(cell);
        f.value_list(fe_values.get_quadrature_points(), scratch.loads);
        FullMatrix<double> &cell_matrix = copy.matrices[0];
        Vector<double>     &cell_rhs    = copy.vectors[0];
        cell_matrix                     = 0;
        cell_rhs                        = 0;
        for (const unsigned int q : fe_values.quadrature_point_indices())
          {
            const double load = scratch.loads[q];
            const double dx   = fe_values.JxW(q);
            for (const unsigned int i : fe_values.dof_indices())
              {
                for (const unsigned int j : fe_values.dof_indices())
                  cell_matrix(i, j) += mu * fe_values.shape_grad(i, q) *
                                       fe_values.shape_grad(j, q) * dx;
                cell_rhs(i) += load * fe_values.shape_value(i, q) * dx;
              }
          }
        cell->get_dof_indices(copy.local_dof_indices[0]);
      };
    const auto copier = [&](const CopyData &copy) {
      constraints.distribute_local_to_global(copy.matrices[0],
                                             copy.vectors[0],
                                             copy.local_dof_indices[0],
                                             matrix,
                                             rhs);
    };
    const Scratch scratch{MeshWorker::ScratchData<dim>(
                            mapping,
                            dof_handler.get_fe(),
                            quadrature,
                            update_values | update_gradients |
                              update_quadrature_points | update_JxW_values),
                          std::vector<double>(quadrature.size())};
    MeshWorker::mesh_loop(dof_handler.active_cell_iterators() |
                            IteratorFilters::LocallyOwnedCell(),
                          cell_worker,
                          copier,
                          scratch,
                          CopyData(dof_handler.get_fe().n_dofs_per_cell()),
                          MeshWorker::assemble_own_cells);
    matrix.compress(VectorOperation::add);
    rhs.compress(VectorOperation::add);

    TrilinosWrappers::PreconditionAMG amg;
    amg.initialize(matrix,
                   VI::elliptic_amg_settings(dof_handler.get_fe().degree > 1));

    SolverControl                           control(1000, 1e-8 * rhs.l2_norm());
    SolverCG<TrilinosWrappers::MPI::Vector> cg(control);
    try
      {
        cg.solve(matrix, solution, rhs, amg);
      }
    catch (const SolverControl::NoConvergence &)
      {
        throw VI::SolverFailure("the reference Poisson solve (CG + AMG) did "
                                "not converge in 1000 iterations");
      }
    constraints.distribute(solution);

    timer.stop();
    const VI::ProcessUsage usage = VI::ProcessUsage::now(comm) - usage_at_start;
    if (solution_out != nullptr)
      *solution_out = std::move(solution);
    return {timer.wall_time(), control.last_step(), usage};
  }


  template PoissonCost
  reference_poisson_solve(const Mapping<2> &,
                          const DoFHandler<2> &,
                          const Quadrature<2> &,
                          const double,
                          const Function<2> &,
                          const Function<2> &,
                          const MPI_Comm,
                          TrilinosWrappers::MPI::Vector *);
} // namespace StepMembranes
