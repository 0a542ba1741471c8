// step-membranes, conforming Q_p: what is done with a solution: its fields,
// errors, VTU output, the next mesh, the cycle's record and the tables.


#include <vi/field_output.h>
#include <vi/marking.h>
#include <vi/membrane_errors.h>
#include <vi/mesh_sequence.h>
#include <vi/nodal_fields.h>

#include "membrane_problem.h"


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
    TimerOutput::Scope       t(timer, "errors");
    const VI::MembraneErrors errors =
      VI::membrane_errors(*mapping, dof_handler, data, u1_h, u2_h, lambda_h);
    error_energy     = errors.energy;
    error_multiplier = errors.multiplier;
    cell_error       = errors.cellwise;
  }


  template <int dim>
  void
  MembraneProblem<dim>::output_results(const unsigned int cycle) const
  {
    if (!parameters.output.write_vtu)
      return;
    TimerOutput::Scope t(timer, "output");

    VI::FieldOutput<dim> output = solution_output();
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
    VI::flag_next_mesh(triangulation,
                       parameters.mesh,
                       final_estimate ? &final_estimate->cell_total : nullptr);
    solution_transfer =
      VI::refine_flagged_cells(triangulation,
                               dof_handler,
                               {&u1_h, &u2_h, &lambda_h},
                               parameters.nonlinear_solver.nested_iteration);
  }


  namespace
  {
    // The terms of the estimate under their keys in summary.json.
    VI::Json
    to_json(const VI::ContactEstimate &e)
    {
      return VI::Json::object({{"eta", e.eta},
                               {"eta_disc", e.eta_disc},
                               {"eta_lin", e.eta_lin},
                               {"eta_alg", e.eta_alg},
                               {"eta_1", e.eta_1},
                               {"flux_disc", e.flux_disc},
                               {"residual", e.residual},
                               {"flux_alg", e.flux_alg},
                               {"remainder", e.remainder},
                               {"nonc_1", e.nonc_1},
                               {"nonc_1_disc", e.nonc_1_disc},
                               {"nonc_1_lin", e.nonc_1_lin},
                               {"nonc_2", e.nonc_2},
                               {"nonc_3", e.nonc_3},
                               {"contact_pos", e.contact_pos},
                               {"contact_cone", e.contact_cone},
                               {"dirichlet", e.dirichlet}});
    }
  } // namespace


  template <int dim>
  void
  MembraneProblem<dim>::record_cycle(const unsigned int cycle)
  {
    petsc_vi_run.reset();
    if (parameters.compare_with_petsc_vi)
      compare_with_petsc_vi(peer_initial_iterate);
    const VI::CycleNumbers numbers = cycle_numbers(cycle);
    VI::add_columns(table, numbers);

    VI::Json record          = VI::to_json(numbers);
    record["dofs"]           = n_fields * dof_handler.n_dofs();
    record["dofs_per_field"] = dof_handler.n_dofs();
    if (final_estimate)
      {
        record["eta_disc"] = final_estimate->eta_disc;
        record["eta_lin"]  = final_estimate->eta_lin;
        record["eta_alg"]  = final_estimate->eta_alg;
        record["estimate"] = to_json(*final_estimate);
        if (parameters.estimators.sharpen_final)
          {
            // whether the sharpened estimate was the smaller one, and
            // whether its multiplier carries the transmitted load
            record["estimate"]["sharpened"]        = final_estimate_sharpened;
            record["estimate"]["transmitted_load"] = final_estimate_transmits;
          }
      }
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
    std::vector<std::string> petsc;
    if (parameters.compare_with_petsc_vi)
      {
        petsc = {"petsc_newton", "petsc_linear", "petsc_distance"};
        if (data.has_exact_solution())
          petsc.push_back("petsc_error");
      }
    run_record.write_tables(
      table,
      {"cycle", "cells", "dofs", "newton", "linear", "contact"},
      {data.has_exact_solution(),
       data.exact_lambda != nullptr,
       parameters.estimators.enabled},
      petsc,
      dim);
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
