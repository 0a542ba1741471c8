// step-membranes, conforming Q_p: what is done with a solution: its fields,
// errors, VTU output, the next mesh, the cycle's record and the tables.

#include <deal.II/base/parallel.h>
#include <deal.II/base/quadrature_lib.h>
#include <deal.II/fe/fe_values.h>
#include <deal.II/grid/filtered_iterator.h>
#include <deal.II/numerics/vector_tools.h>

#include <vi/cell_function_values.h>
#include <vi/field_output.h>
#include <vi/nodal_fields.h>

#include "membrane_problem.h"

#include <algorithm>
#include <cmath>
#include <fstream>

namespace StepMembranes
{
  // The inverse map: X3_i = <lambda_h, psi_i>_h / D_i, i.e. lambda_h(x_i)
  // for p = 1 and (lambda_h, psi_i) for p >= 2, on the contact nodes.
  template <int dim>
  void
  MembraneProblem<dim>::compute_dual_coefficients(const Vector &lambda,
                                                  Vector       &X3) const
  {
    Vector values(owned_nodes, comm);
    if (fe.degree == 1)
      values = lambda;
    else
      mass_matrix.vmult(values, lambda);
    X3 = 0;
    for (const types::global_dof_index i :
         contact_system.contact_rows().nodes())
      X3(i) = values(i);
    X3.compress(VectorOperation::insert);
  }


  // The discrete solution as finite element functions, the contact set.
  template <int dim>
  void
  MembraneProblem<dim>::postprocess()
  {
    TimerOutput::Scope t(timer, "postprocess");
    n_contact_nodes =
      make_solution_fields(contact_system, multiplier_function, solution);
  }


  // Energy norm |||u - u_h|||^2 = mu1 |u1 - u1h|_1^2 + mu2 |u2 - u2h|_1^2,
  // and the L2 error of the multiplier where it is known.
  template <int dim>
  void
  MembraneProblem<dim>::compute_errors()
  {
    if (!data.has_exact_solution())
      return;
    TimerOutput::Scope t(timer, "errors");

    // On the cells of all threads (VectorTools::integrate_difference runs on
    // one), with the data's own gradients: for a parsed expression these
    // are fourth-order differences, eight evaluations per point, which make
    // this the longest part of a run after the solve.
    const QGauss<dim>      error_quadrature(fe.degree + 3);
    const unsigned int     n_cells = triangulation.n_active_cells();
    dealii::Vector<double> cell_u1(n_cells), cell_u2(n_cells),
      cell_lambda(n_cells);
    on_owned_cells_in_parallel(
      [&](const auto &cells, const std::size_t begin, const std::size_t end) {
        FEValues<dim>       values(*mapping,
                             fe,
                             error_quadrature,
                             update_values | update_gradients |
                               update_quadrature_points | update_JxW_values);
        const unsigned int  n_q = error_quadrature.size();
        std::vector<double> coefficients, lambda(n_q), exact_lambda(n_q);
        std::vector<Tensor<1, dim>> gradient(n_q), exact_gradient(n_q);
        const Vector               *u[2]      = {&u1_h, &u2_h};
        const Function<dim>        *exact[2]  = {data.exact_u1.get(),
                                                 data.exact_u2.get()};
        dealii::Vector<double>     *cell_u[2] = {&cell_u1, &cell_u2};
        for (std::size_t c = begin; c < end; ++c)
          {
            const auto &cell = cells[c];
            values.reinit(cell);
            const auto &points = values.get_quadrature_points();
            for (unsigned int a = 0; a < 2; ++a)
              {
                VI::cell_function_values(
                  values, cell, *u[a], coefficients, nullptr, &gradient);
                exact[a]->gradient_list(points, exact_gradient);
                double sum = 0;
                for (unsigned int q = 0; q < n_q; ++q)
                  sum += (exact_gradient[q] - gradient[q]).norm_square() *
                         values.JxW(q);
                (*cell_u[a])[cell->active_cell_index()] = std::sqrt(sum);
              }
            if (data.exact_lambda)
              {
                VI::cell_function_values(
                  values, cell, lambda_h, coefficients, &lambda);
                data.exact_lambda->value_list(points, exact_lambda);
                double sum = 0;
                for (unsigned int q = 0; q < n_q; ++q)
                  sum +=
                    std::pow(exact_lambda[q] - lambda[q], 2) * values.JxW(q);
                cell_lambda[cell->active_cell_index()] = std::sqrt(sum);
              }
          }
      });
    const auto global = [&](const dealii::Vector<double> &cellwise) {
      return VectorTools::compute_global_error(triangulation,
                                               cellwise,
                                               VectorTools::L2_norm);
    };
    cell_error.reinit(n_cells);
    for (unsigned int K = 0; K < n_cells; ++K)
      cell_error[K] = std::sqrt(data.mu1 * cell_u1[K] * cell_u1[K] +
                                data.mu2 * cell_u2[K] * cell_u2[K]);
    const double e1 = global(cell_u1), e2 = global(cell_u2);
    error_energy = std::sqrt(data.mu1 * e1 * e1 + data.mu2 * e2 * e2);
    if (data.exact_lambda)
      error_multiplier = global(cell_lambda);
  }


  template <int dim>
  void
  MembraneProblem<dim>::output_results(const unsigned int cycle) const
  {
    if (!parameters.output.write_vtu)
      return;
    TimerOutput::Scope t(timer, "output");

    VI::FieldOutput<dim> output(*mapping,
                                geometry,
                                dof_handler,
                                {u1_h, u2_h, gap_h, lambda_h, &contact_set});
    output.add_indicators(final_estimate ? &*final_estimate : nullptr);
    if (data.has_exact_solution())
      output.add_cell_field(cell_error, "error_energy");
    output.write(parameters.output.directory, cycle, 2, comm);
  }


  // Global refinement, or the cells marked by the estimate of the last
  // solution; with nested iteration the current solution is carried to the
  // new mesh by SolutionTransfer (as finite element functions: the dual
  // coefficients X3 are recomputed on the new mesh).
  template <int dim>
  void
  MembraneProblem<dim>::refine_mesh()
  {
    TimerOutput::Scope t(timer, "refinement");
    const auto        &mesh = parameters.mesh;
    if (mesh.refinement == "adaptive")
      {
        Assert(final_estimate, ExcInternalError());
        VI::mark_cells_for_refinement(triangulation,
                                      final_estimate->cell_total,
                                      mesh.marking,
                                      mesh.refinement_fraction);
      }
    else
      for (const auto &cell : triangulation.active_cell_iterators())
        if (cell->is_locally_owned())
          cell->set_refine_flag();
    triangulation.prepare_coarsening_and_refinement();

    if (parameters.nonlinear_solver.nested_iteration)
      {
        solution_transfer = std::make_unique<
          parallel::distributed::SolutionTransfer<dim, Vector>>(dof_handler);
        solution_transfer->prepare_for_coarsening_and_refinement(
          std::vector<const Vector *>{&u1_h, &u2_h, &lambda_h});
      }
    triangulation.execute_coarsening_and_refinement();
  }


  namespace
  {
    VI::Json
    to_json(const VI::ContactEstimate &e)
    {
      VI::Json json        = VI::Json::object();
      json["eta"]          = e.eta;
      json["eta_disc"]     = e.eta_disc;
      json["eta_lin"]      = e.eta_lin;
      json["eta_alg"]      = e.eta_alg;
      json["eta_1"]        = e.eta_1;
      json["flux_disc"]    = e.flux_disc;
      json["residual"]     = e.residual;
      json["flux_alg"]     = e.flux_alg;
      json["remainder"]    = e.remainder;
      json["nonc_1"]       = e.nonc_1;
      json["nonc_1_disc"]  = e.nonc_1_disc;
      json["nonc_1_lin"]   = e.nonc_1_lin;
      json["nonc_2"]       = e.nonc_2;
      json["nonc_3"]       = e.nonc_3;
      json["contact_pos"]  = e.contact_pos;
      json["contact_cone"] = e.contact_cone;
      json["dirichlet"]    = e.dirichlet;
      return json;
    }
  } // namespace


  template <int dim>
  void
  MembraneProblem<dim>::record_cycle(const unsigned int cycle)
  {
    const double wall = run_record.cycle_seconds();

    table.add_value("cycle", cycle);
    table.add_value("cells", triangulation.n_global_active_cells());
    table.add_value("dofs", dof_handler.n_dofs());
    table.add_value("newton", newton_report.iterations);
    table.add_value("linear", newton_report.linear_iterations);
    table.add_value("contact", n_contact_nodes);
    if (data.has_exact_solution())
      {
        table.add_value("error_energy", error_energy);
        table.set_scientific("error_energy", true);
        table.set_precision("error_energy", 4);
        if (data.exact_lambda)
          {
            table.add_value("error_lambda", error_multiplier);
            table.set_scientific("error_lambda", true);
            table.set_precision("error_lambda", 4);
          }
      }
    if (final_estimate)
      {
        table.add_value("eta", final_estimate->eta);
        table.set_scientific("eta", true);
        table.set_precision("eta", 4);
        if (data.has_exact_solution())
          {
            table.add_value("effectivity", final_estimate->eta / error_energy);
            table.set_precision("effectivity", 3);
          }
      }
    table.add_value("wall_s", wall);
    table.set_precision("wall_s", 3);

    VI::Json record             = VI::Json::object();
    record["cycle"]             = cycle;
    record["cells"]             = triangulation.n_global_active_cells();
    record["dofs"]              = n_fields * dof_handler.n_dofs();
    record["dofs_per_field"]    = dof_handler.n_dofs();
    record["newton_iterations"] = newton_report.iterations;
    record["linear_iterations"] = newton_report.linear_iterations;
    record["contact_nodes"]     = n_contact_nodes;
    if (data.has_exact_solution())
      record["error_energy"] = error_energy;
    if (data.exact_lambda)
      record["error_lambda_l2"] = error_multiplier;
    if (final_estimate)
      {
        record["eta"]      = final_estimate->eta;
        record["eta_disc"] = final_estimate->eta_disc;
        record["eta_lin"]  = final_estimate->eta_lin;
        record["eta_alg"]  = final_estimate->eta_alg;
        if (data.has_exact_solution())
          record["effectivity"] = final_estimate->eta / error_energy;
        record["estimate"] = to_json(*final_estimate);
        if (parameters.estimators.sharpen_final)
          // whether the equilibrated estimate was the smaller one
          record["estimate"]["sharpened"] = final_estimate_sharpened;
      }
    record["wall_seconds"]  = wall;
    record["solve_seconds"] = solve_timer.wall_time();
    record["solve_usage"]   = VI::to_json(solve_usage);
    // This cycle's share of every TimerOutput section.
    record["timing"] = run_record.cycle_timing();
    // Newton steps, and every estimate (inner checks and accepted iterates).
    record["newton_steps"] = VI::newton_steps(newton_report);
    record["iterations"]   = VI::to_json(stopping.records, true);
    record_benchmarks(record);
    run_record.add(record);
  }


  // The convergence table, with rates in h (from the DoF counts, d = 2):
  // to the screen with the wall time, and to convergence.txt without it, so
  // that the file is reproducible and diffable.
  template <int dim>
  void
  MembraneProblem<dim>::write_tables() const
  {
    std::vector<std::string> errors;
    if (data.has_exact_solution())
      errors.push_back("error_energy");
    if (data.exact_lambda)
      errors.push_back("error_lambda");
    if (parameters.estimators.enabled)
      errors.push_back("eta");
    std::vector<std::string> columns = {
      "cycle", "cells", "dofs", "newton", "linear", "contact"};
    columns.insert(columns.end(), errors.begin(), errors.end());
    if (parameters.estimators.enabled && data.has_exact_solution())
      columns.push_back("effectivity");
    if (parameters.compare_with_petsc_vi)
      {
        columns.insert(columns.end(),
                       {"petsc_newton", "petsc_linear", "petsc_distance"});
        if (data.has_exact_solution())
          columns.push_back("petsc_error");
      }
    run_record.write_tables(table, errors, columns, dim);
  }


  // Explicit instantiations of this file's members.
  template void
  MembraneProblem<2>::compute_dual_coefficients(const Vector &lambda,
                                                Vector       &X3) const;
  template void
  MembraneProblem<2>::postprocess();
  template void
  MembraneProblem<2>::compute_errors();
  template void
  MembraneProblem<2>::output_results(const unsigned int cycle) const;
  template void
  MembraneProblem<2>::refine_mesh();
  template void
  MembraneProblem<2>::record_cycle(const unsigned int cycle);
  template void
  MembraneProblem<2>::write_tables() const;
} // namespace StepMembranes
