
#include <vi/field_output.h>
#include <vi/marking.h>
#include <vi/membrane_errors.h>
#include <vi/mesh_sequence.h>
#include <vi/nodal_fields.h>
#include <vi/summary.h>

#include "hho_problem.h"

#include <cmath>

namespace StepHHO
{
  // ------------------------------------------------------------------------
  // Results.

  // The cell unknowns as FE_DGP functions: u_alpha,K = sum_j (T X_alpha)_j
  // P_j, lambda_h with coefficients M^{-1} V^T X3 (from X3 = T^T M c).
  template <int dim>
  void
  HHOProblem<dim>::cell_fields()
  {
    const unsigned int            n_c = cell_fe.n_dofs_per_cell();
    TrilinosWrappers::MPI::Vector u1(owned_nodes, comm), u2(owned_nodes, comm),
      gap(owned_nodes, comm), lambda(owned_nodes, comm);

    std::vector<types::global_dof_index> nodes(n_c);
    Vector<double>                       x(n_c), c(n_c), Vx(n_c);
    FullMatrix<double>                   M_inverse;
    for (const auto &cell : cell_dof_handler.active_cell_iterators())
      if (cell->is_locally_owned())
        {
          cell->get_dof_indices(nodes);
          Vector<double> c_alpha[2] = {Vector<double>(n_c),
                                       Vector<double>(n_c)};
          for (unsigned int alpha = 0; alpha < 2; ++alpha)
            {
              for (unsigned int I = 0; I < n_c; ++I)
                x(I) = solution(index(nodes[I], alpha));
              T.vmult(c_alpha[alpha], x);
            }
          for (unsigned int I = 0; I < n_c; ++I)
            x(I) = solution(index(nodes[I], multiplier));
          V.Tvmult(Vx, x);
          M_inverse = local_matrices_of(cell).mass;
          M_inverse.gauss_jordan();
          M_inverse.vmult(c, Vx);
          for (unsigned int j = 0; j < n_c; ++j)
            {
              u1(nodes[j])     = c_alpha[0](j);
              u2(nodes[j])     = c_alpha[1](j);
              gap(nodes[j])    = c_alpha[0](j) - c_alpha[1](j);
              lambda(nodes[j]) = c(j);
            }
        }
    for (auto *v : {&u1, &u2, &gap, &lambda})
      v->compress(VectorOperation::insert);
    ghosted_nodes.copy(u1, u1_h);
    ghosted_nodes.copy(u2, u2_h);
    ghosted_nodes.copy(gap, gap_h);
    ghosted_nodes.copy(lambda, lambda_h);
  }


  // The cell fields of the solution, the contact set and the estimate (that
  // of Newton's stopping test if it has computed one at this iterate).
  template <int dim>
  void
  HHOProblem<dim>::postprocess()
  {
    TimerOutput::Scope t(timer, "postprocess");
    cell_fields();

    // Nodes where u1 = u2 is enforced, and their share on each cell.
    const unsigned int                   n_c = cell_fe.n_dofs_per_cell();
    std::vector<types::global_dof_index> nodes(n_c);
    TrilinosWrappers::MPI::Vector        indicator(owned_nodes, comm);
    n_contact_nodes = contact_rows.contact_set(solution, indicator);
    contact_fraction.reinit(triangulation.n_active_cells());
    for (const auto &cell : cell_dof_handler.active_cell_iterators())
      if (cell->is_locally_owned())
        {
          cell->get_dof_indices(nodes);
          double in_contact = 0;
          for (const auto i : nodes)
            in_contact += indicator(i);
          contact_fraction(cell->active_cell_index()) = in_contact / n_c;
        }

    last_estimate.reset();
    if (parameters.estimators)
      last_estimate = stopping.final_estimate ?
                        std::move(stopping.final_estimate) :
                        std::optional(estimate());
  }


  // The energy error of the slides, |||u - u_h|||^2 = sum_K mu1 |u1 -
  // u1,K|^2_{1,K} + mu2 |u2 - u2,K|^2_{1,K} with the cell polynomials, and the
  // L2 error of the multiplier.
  template <int dim>
  void
  HHOProblem<dim>::compute_errors()
  {
    if (!data.has_exact_solution())
      return;
    TimerOutput::Scope       t(timer, "errors");
    const VI::MembraneErrors errors = VI::membrane_errors(
      *mapping, cell_dof_handler, data, u1_h, u2_h, lambda_h);
    error_energy     = errors.energy;
    error_multiplier = errors.multiplier;
  }


  // The cell unknowns for ParaView: u1, u2, gap = u1 - u2 and lambda as
  // discontinuous P_p functions, the share of each cell's nodes in contact,
  // the owning process, and with the estimate its cellwise indicators.
  template <int dim>
  void
  HHOProblem<dim>::output_results(const unsigned int cycle) const
  {
    if (!parameters.output.write_vtu)
      return;
    TimerOutput::Scope t(timer, "output");

    VI::FieldOutput<dim> output(
      *mapping,
      domain.has_curved_cells(),
      cell_dof_handler,
      {u1_h, u2_h, gap_h, lambda_h, nullptr, &contact_fraction});
    output.add_indicators(last_estimate ? &*last_estimate : nullptr);
    output.write(parameters.output.directory, cycle, 2, comm);
  }


  // Global refinement, or adaptive: the cells marked by the estimate's
  // indicators (faces between refinement levels: constrain_hanging_faces()).
  // With nested iteration the cell polynomials u1,K, u2,K and lambda_h are
  // carried to the new mesh by SolutionTransfer.
  template <int dim>
  void
  HHOProblem<dim>::refine_mesh()
  {
    TimerOutput::Scope t(timer, "refinement");
    VI::flag_next_mesh(triangulation,
                       parameters.mesh,
                       last_estimate ? &last_estimate->cell_total : nullptr);
    solution_transfer =
      VI::refine_flagged_cells(triangulation,
                               cell_dof_handler,
                               {&u1_h, &u2_h, &lambda_h},
                               parameters.nonlinear_solver.nested_iteration);
  }


  // Unknowns as counted in the seed: 2 (cells dim P_p + interior faces dim
  // P_{p-1}) + cells dim P_p (the multiplier) without static condensation,
  // 2 (interior faces) dim P_{p-1} with it; the fixed boundary face values
  // and the coarse faces between refinement levels are not unknowns.
  template <int dim>
  VI::CycleNumbers
  HHOProblem<dim>::cycle_numbers(const unsigned int cycle) const
  {
    const unsigned long long condensed =
      2 *
      (face_dof_handler.n_dofs() - n_boundary_face_dofs - n_hanging_face_dofs);
    VI::CycleNumbers numbers =
      measured(cycle,
               triangulation.n_global_active_cells(),
               n_fields * cell_dof_handler.n_dofs() + condensed,
               "Newton-" + C.name(),
               newton_report.linear_iterations > 0 ? "CG" : "");
    numbers.dofs_condensed = condensed;
    if (last_estimate)
      numbers.estimate = last_estimate->broken;
    return numbers;
  }


  template <int dim>
  void
  HHOProblem<dim>::record_cycle(const unsigned int cycle)
  {
    const VI::CycleNumbers numbers = cycle_numbers(cycle);
    VI::add_columns(table, numbers);

    VI::Json record          = VI::to_json(numbers);
    record["dofs"]           = numbers.dofs;
    record["dofs_condensed"] = *numbers.dofs_condensed;
    record["dofs_cell"]      = n_fields * cell_dof_handler.n_dofs();
    // The TimerOutput sections of this cycle, and the Newton steps (with
    // their active sets and, during the continuation, the smoothing).
    record["timing"]       = run_record.cycle_timing();
    record["newton_steps"] = VI::newton_steps(newton_report);
    if (stopping.adaptive())
      record["iterations"] = VI::to_json(stopping.records, true);
    if (last_estimate)
      {
        // The parts of the bound (doc/reference.md, "A posteriori estimate
        // of HHO") and the jumps of the cell polynomials (not in it).
        const VI::DGContactEstimate &e = *last_estimate;
        record["estimate"] = VI::Json::object({{"flux", e.flux_disc},
                                               {"residual", e.residual},
                                               {"nonconformity_1", e.nonc_1},
                                               {"nonconformity_2", e.nonc_2},
                                               {"nonconformity_3", e.nonc_3},
                                               {"contact", e.contact_cone},
                                               {"jump", e.jump},
                                               {"eta_disc", e.broken_disc},
                                               {"eta_lin", e.eta_lin},
                                               {"eta_alg", e.eta_alg},
                                               {"nonc_1_lin", e.nonc_1_lin},
                                               {"nonc_2_lin", e.nonc_2_lin},
                                               {"contact_lin", e.contact_lin}});
      }
    run_record.add(record);
  }


  // The convergence table, with rates in h (from the DoF counts, d = 2):
  // to the screen with the linear iterations and the wall time, and to
  // convergence.txt without them, so that the file is reproducible on any
  // number of processes (AMG, and with it the CG iteration count, depends
  // on the partition) and diffable.
  template <int dim>
  void
  HHOProblem<dim>::write_tables() const
  {
    run_record.write_tables(
      table,
      {"cycle", "cells", "dofs", "dofs_condensed", "newton", "contact"},
      {data.has_exact_solution(),
       data.exact_lambda != nullptr,
       parameters.estimators},
      {},
      dim);
  }


  template void
  HHOProblem<2>::cell_fields();
  template void
  HHOProblem<2>::postprocess();
  template void
  HHOProblem<2>::compute_errors();
  template void
  HHOProblem<2>::output_results(const unsigned int) const;
  template void
  HHOProblem<2>::refine_mesh();
  template VI::CycleNumbers
  HHOProblem<2>::cycle_numbers(const unsigned int) const;
  template void
  HHOProblem<2>::record_cycle(const unsigned int);
  template void
  HHOProblem<2>::write_tables() const;
} // namespace StepHHO
