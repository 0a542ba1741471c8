#include "reference_poisson.h"

#include <deal.II/base/index_set.h>
#include <deal.II/base/timer.h>
#include <deal.II/dofs/dof_tools.h>
#include <deal.II/fe/fe_values.h>
#include <deal.II/lac/affine_constraints.h>
#include <deal.II/lac/dynamic_sparsity_pattern.h>
#include <deal.II/lac/full_matrix.h>
#include <deal.II/lac/solver_cg.h>
#include <deal.II/lac/solver_control.h>
#include <deal.II/lac/sparsity_tools.h>
#include <deal.II/lac/trilinos_precondition.h>
#include <deal.II/lac/trilinos_sparse_matrix.h>
#include <deal.II/lac/trilinos_vector.h>
#include <deal.II/numerics/vector_tools.h>

#include <vi/errors.h>
#include <vi/linear_solvers.h>

#include <map>

namespace StepMembranes
{
  using namespace dealii;

  template <int dim>
  PoissonCost
  reference_poisson_solve(const Mapping<dim>    &mapping,
                          const DoFHandler<dim> &dof_handler,
                          const Quadrature<dim> &quadrature,
                          const double           mu,
                          const Function<dim>   &f,
                          const Function<dim>   &g,
                          const MPI_Comm         comm)
  {
    Timer timer(comm, /*sync_lap_times=*/true);

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

    FEValues<dim>       fe_values(mapping,
                            dof_handler.get_fe(),
                            quadrature,
                            update_values | update_gradients |
                              update_quadrature_points | update_JxW_values);
    const unsigned int  n = dof_handler.get_fe().n_dofs_per_cell();
    FullMatrix<double>  cell_matrix(n, n);
    Vector<double>      cell_rhs(n);
    std::vector<double> load(quadrature.size());
    std::vector<types::global_dof_index> dofs(n);
    for (const auto &cell : dof_handler.active_cell_iterators())
      if (cell->is_locally_owned())
        {
          fe_values.reinit(cell);
          f.value_list(fe_values.get_quadrature_points(), load);
          cell_matrix = 0;
          cell_rhs    = 0;
          for (const unsigned int q : fe_values.quadrature_point_indices())
            for (unsigned int i = 0; i < n; ++i)
              {
                for (unsigned int j = 0; j < n; ++j)
                  cell_matrix(i, j) += mu * fe_values.shape_grad(i, q) *
                                       fe_values.shape_grad(j, q) *
                                       fe_values.JxW(q);
                cell_rhs(i) +=
                  load[q] * fe_values.shape_value(i, q) * fe_values.JxW(q);
              }
          cell->get_dof_indices(dofs);
          constraints.distribute_local_to_global(
            cell_matrix, cell_rhs, dofs, matrix, rhs);
        }
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
    return {timer.wall_time(), control.last_step()};
  }


  template PoissonCost
  reference_poisson_solve(const Mapping<2> &,
                          const DoFHandler<2> &,
                          const Quadrature<2> &,
                          const double,
                          const Function<2> &,
                          const Function<2> &,
                          const MPI_Comm);
} // namespace StepMembranes
