#include <deal.II/base/quadrature_lib.h>
#include <deal.II/fe/fe_values.h>
#include <deal.II/meshworker/mesh_loop.h>
#include <deal.II/meshworker/scratch_data.h>
#include <deal.II/numerics/vector_tools.h>

#include <vi/membrane_errors.h>
#include <vi/test_cases.h>

#include <cmath>

namespace VI
{
  using namespace dealii;

  template <int dim>
  MembraneErrors
  membrane_errors(const Mapping<dim>                  &mapping,
                  const DoFHandler<dim>               &dof_handler,
                  const MembraneData<dim>             &data,
                  const TrilinosWrappers::MPI::Vector &u1_h,
                  const TrilinosWrappers::MPI::Vector &u2_h,
                  const TrilinosWrappers::MPI::Vector &lambda_h)
  {
    const auto        &triangulation = dof_handler.get_triangulation();
    const unsigned int n_cells       = triangulation.n_active_cells();
    Vector<double>     cell_u1(n_cells), cell_u2(n_cells), cell_lambda(n_cells);

    const TrilinosWrappers::MPI::Vector *u[2] = {&u1_h, &u2_h};
    const Function<dim> *exact[2]  = {data.exact_u1.get(), data.exact_u2.get()};
    Vector<double>      *cell_u[2] = {&cell_u1, &cell_u2};
    const std::string    name[2]   = {"u1", "u2"};
    const FEValuesExtractors::Scalar scalar(0);

    // Each cell writes its own entries: there is nothing to copy.
    struct NoCopy
    {
    };
    const auto local =
      [&](const auto &cell, MeshWorker::ScratchData<dim> &scratch, NoCopy &) {
        const FEValues<dim> &values = scratch.reinit(cell);
        const auto          &points = values.get_quadrature_points();
        // Arrays of the thread, kept in its scratch from cell to cell.
        auto &storage = scratch.get_general_data_storage();
        auto &exact_gradient =
          storage
            .template get_or_add_object_with_name<std::vector<Tensor<1, dim>>>(
              "exact gradient", points.size());
        auto &exact_lambda =
          storage.template get_or_add_object_with_name<std::vector<double>>(
            "exact lambda", points.size());
        // (over an obstacle, membrane 2 is the obstacle: no error of its own)
        for (unsigned int a = 0; a < (data.obstacle ? 1 : 2); ++a)
          {
            scratch.extract_local_dof_values(name[a], *u[a]);
            const auto &gradient = scratch.get_gradients(name[a], scalar);
            exact[a]->gradient_list(points, exact_gradient);
            double sum = 0;
            for (const unsigned int q : values.quadrature_point_indices())
              sum +=
                (exact_gradient[q] - gradient[q]).norm_square() * values.JxW(q);
            (*cell_u[a])[cell->active_cell_index()] = std::sqrt(sum);
          }
        if (data.exact_lambda)
          {
            scratch.extract_local_dof_values("lambda", lambda_h);
            const auto &lambda = scratch.get_values("lambda", scalar);
            data.exact_lambda->value_list(points, exact_lambda);
            double sum = 0;
            for (const unsigned int q : values.quadrature_point_indices())
              sum += std::pow(exact_lambda[q] - lambda[q], 2) * values.JxW(q);
            cell_lambda[cell->active_cell_index()] = std::sqrt(sum);
          }
      };
    NoCopy nothing;
    MeshWorker::mesh_loop(
      dof_handler.begin_active(),
      dof_handler.end(),
      local,
      [](const NoCopy &) {},
      MeshWorker::ScratchData<dim>(mapping,
                                   dof_handler.get_fe(),
                                   QGauss<dim>(dof_handler.get_fe().degree + 3),
                                   update_values | update_gradients |
                                     update_quadrature_points |
                                     update_JxW_values),
      nothing,
      MeshWorker::assemble_own_cells);

    const auto global = [&](const Vector<double> &cellwise) {
      return VectorTools::compute_global_error(triangulation,
                                               cellwise,
                                               VectorTools::L2_norm);
    };
    MembraneErrors errors;
    errors.cellwise.reinit(n_cells);
    for (unsigned int K = 0; K < n_cells; ++K)
      errors.cellwise[K] = std::sqrt(data.mu1 * cell_u1[K] * cell_u1[K] +
                                     data.mu2 * cell_u2[K] * cell_u2[K]);
    const double e1 = global(cell_u1), e2 = global(cell_u2);
    errors.energy = std::sqrt(data.mu1 * e1 * e1 + data.mu2 * e2 * e2);
    if (data.exact_lambda)
      errors.multiplier = global(cell_lambda);
    return errors;
  }


  template MembraneErrors
  membrane_errors(const Mapping<2> &,
                  const DoFHandler<2> &,
                  const MembraneData<2> &,
                  const TrilinosWrappers::MPI::Vector &,
                  const TrilinosWrappers::MPI::Vector &,
                  const TrilinosWrappers::MPI::Vector &);
} // namespace VI
