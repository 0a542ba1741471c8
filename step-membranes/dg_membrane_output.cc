// step-membranes, interior penalty dG: the fields of a solution, errors,
// output, refinement and the cycle's record.

#include <vi/errors.h>
#include <vi/field_output.h>
#include <vi/marking.h>
#include <vi/membrane_errors.h>
#include <vi/mesh_sequence.h>
#include <vi/nodal_fields.h>

#include "dg_membrane_problem.h"

#include <cmath>

namespace StepMembranes
{
  template <int dim>
  void
  DGMembraneProblem<dim>::postprocess()
  {
    TimerOutput::Scope t(timer, "postprocess");
    Vector             u1(owned_nodes, comm), u2(owned_nodes, comm),
      field(owned_nodes, comm);
    VI::NodalFields::extract(solution, VI::NodalFields::u1, u1);
    VI::NodalFields::extract(solution, VI::NodalFields::u2, u2);
    u1_h = u1;
    u2_h = u2;
    u1 -= u2;
    gap_h = u1;
    VI::NodalFields::extract(solution, multiplier, field);
    multiplier_function(field, lambda_h);
    n_contact_nodes =
      contact_system.contact_rows().contact_set(solution, field);
    contact_set = field;
  }


  // The dG energy error |||u - u_h|||_dG^2 = sum_alpha mu_alpha
  // (|grad_h (u_alpha - u_alpha,h)|^2 + sum_F gamma_F / h_F |[[u_alpha -
  // u_alpha,h]]|_F^2): the broken H1 seminorm and the jumps of u_h (with
  // g - u_h on the boundary); and the L2 error of the multiplier.
  template <int dim>
  void
  DGMembraneProblem<dim>::compute_errors()
  {
    if (!data.has_exact_solution())
      return;
    TimerOutput::Scope       t(timer, "errors");
    const VI::MembraneErrors errors =
      VI::membrane_errors(*mapping, dof_handler, data, u1_h, u2_h, lambda_h);
    error_broken = errors.energy;
    error_jump   = VI::jump_seminorm(*mapping,
                                   dof_handler,
                                   face_quadrature,
                                   penalty,
                                   data.mu1,
                                   data.mu2,
                                   u1_h,
                                   u2_h,
                                   *data.g1,
                                   *data.g2,
                                   nullptr,
                                   &domain);
    error_energy =
      std::sqrt(error_broken * error_broken + error_jump * error_jump);
    error_multiplier = errors.multiplier;
  }


  template <int dim>
  void
  DGMembraneProblem<dim>::output_results(const unsigned int cycle) const
  {
    if (!parameters.output.write_vtu)
      return;
    TimerOutput::Scope t(timer, "output");
    // The broken functions of the nodes, with the indicators of the
    // guaranteed estimate.
    VI::FieldOutput<dim> output(*mapping,
                                domain.has_curved_cells(),
                                dof_handler,
                                {u1_h, u2_h, gap_h, lambda_h, &contact_set});
    output.add_indicators(final_estimate ? &*final_estimate : nullptr);
    output.write(parameters.output.directory, cycle, 2, comm);
  }


  template <int dim>
  void
  DGMembraneProblem<dim>::refine_mesh()
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
    to_json(const VI::DGContactEstimate &e)
    {
      return VI::Json::object({{"eta", e.eta},
                               {"eta_broken", e.broken},
                               {"jump", e.jump},
                               {"flux", e.flux_disc},
                               {"residual", e.residual},
                               {"remainder", e.remainder},
                               {"nonc_1", e.nonc_1},
                               {"oswald", e.oswald},
                               {"nonc_2", e.nonc_2},
                               {"nonc_3", e.nonc_3},
                               {"contact_pos", e.contact_pos},
                               {"contact_cone", e.contact_cone},
                               {"contact_lin", e.contact_lin},
                               {"dirichlet", e.dirichlet}});
    }
  } // namespace


  template <int dim>
  void
  DGMembraneProblem<dim>::record_cycle(const unsigned int cycle)
  {
    const VI::CycleNumbers numbers = cycle_numbers(cycle);
    VI::add_columns(table, numbers);

    VI::Json record          = VI::to_json(numbers);
    record["dofs"]           = n_fields * dof_handler.n_dofs();
    record["dofs_per_field"] = dof_handler.n_dofs();
    if (data.has_exact_solution())
      {
        record["error_broken"] = error_broken;
        record["error_jump"]   = error_jump;
      }
    if (final_estimate)
      {
        const VI::DGContactEstimate &e = *final_estimate;
        record["eta_disc"]             = e.eta_disc;
        record["eta_lin"]              = e.eta_lin;
        record["eta_alg"]              = e.eta_alg;
        if (data.has_exact_solution())
          record["effectivity_broken"] = e.broken / error_broken;
        record["estimate"] = to_json(e);
      }
    // Newton steps, and every estimate (inner checks and accepted iterates).
    record["newton_steps"] = VI::newton_steps(newton_report);
    record["iterations"]   = VI::to_json(stopping.records, true);
    run_record.add(record);
  }


  // The convergence table with rates in h (from the DoF counts): on the
  // screen with the wall time, in convergence.txt without it.
  template <int dim>
  void
  DGMembraneProblem<dim>::write_tables() const
  {
    run_record.write_tables(
      table,
      {"cycle", "cells", "dofs", "newton", "linear", "contact"},
      {data.has_exact_solution(),
       data.exact_lambda != nullptr,
       parameters.estimators.enabled},
      {},
      dim);
  }


  // Explicit instantiations of this file's members.
  template void
  DGMembraneProblem<2>::postprocess();
  template void
  DGMembraneProblem<2>::compute_errors();
  template void
  DGMembraneProblem<2>::output_results(const unsigned int cycle) const;
  template void
  DGMembraneProblem<2>::refine_mesh();
  template void
  DGMembraneProblem<2>::record_cycle(const unsigned int cycle);
  template void
  DGMembraneProblem<2>::write_tables() const;
} // namespace StepMembranes
