// step-parabolic: what is done with an accepted step: its fields and errors,
// the VTU output, the step's record, the tables and summary.json.

#include <deal.II/base/quadrature_lib.h>
#include <deal.II/fe/fe_values.h>
#include <deal.II/grid/filtered_iterator.h>
#include <deal.II/numerics/data_out.h>
#include <deal.II/numerics/vector_tools.h>

#include <vi/field_output.h>
#include <vi/nodal_fields.h>

#include "parabolic_problem.h"

#include <cmath>
#include <fstream>
#include <iomanip>
#include <sstream>

namespace StepParabolic
{
  // The solution of the step as finite element functions; the contact set
  // (and, for the ring test, its size in every ring).
  template <int dim>
  void
  ParabolicProblem<dim>::postprocess()
  {
    TimerOutput::Scope t(timer, "postprocess");
    n_contact_nodes =
      make_solution_fields(contact_system, multiplier_function, solution);
    contact_per_ring.clear();
    if (!node_ring.empty())
      {
        std::vector<double> local(5, 0.), total(5);
        for (std::size_t k = 0; k < node_ring.size(); ++k)
          if (contact_set(owned_nodes.nth_index_in_set(k)) > 0.5)
            local[node_ring[k]] += 1.;
        Utilities::MPI::sum(local, comm, total);
        for (const double n : total)
          contact_per_ring.push_back(std::llround(n));
      }
  }


  // Only with an exact solution: int_In |||u - u_ht|||^2 dt (two Gauss points
  // in time, u_ht linear between u_h^(n-1) and u_h^n), |u(t_n) - u_h^n| and
  // |||u(t_n) - u_h^n|||.
  template <int dim>
  void
  ParabolicProblem<dim>::compute_errors()
  {
    TimerOutput::Scope t(timer, "errors");

    // (over an obstacle, membrane 2 is the obstacle: no error of its own)
    const auto energy_error = [&](const Vector &v1, const Vector &v2) {
      const double e1 =
        global_error(v1, *data.exact_u1, VectorTools::H1_seminorm);
      const double e2 =
        data.obstacle ?
          0. :
          global_error(v2, *data.exact_u2, VectorTools::H1_seminorm);
      return data.mu1 * e1 * e1 + data.mu2 * e2 * e2;
    };

    Vector u1(owned_nodes, comm), u2(owned_nodes, comm);
    VI::NodalFields::extract(solution, VI::NodalFields::u1, u1);
    VI::NodalFields::extract(solution, VI::NodalFields::u2, u2);
    const QGauss<1> in_time(2);
    Vector          v1, v2;
    double          integral = 0;
    for (unsigned int k = 0; k < in_time.size(); ++k)
      {
        const double theta = in_time.point(k)[0];
        data.set_time(time + theta * time_step);
        interpolate_in_time(previous_owned[0], u1, theta, v1);
        interpolate_in_time(previous_owned[1], u2, theta, v2);
        integral += in_time.weight(k) * time_step * energy_error(v1, v2);
      }
    data.set_time(time + time_step);
    totals.error_squared += integral;
    step_error_energy = std::sqrt(energy_error(u1_h, u2_h));
    const double l1 = global_error(u1_h, *data.exact_u1, VectorTools::L2_norm);
    const double l2 =
      data.obstacle ? 0. :
                      global_error(u2_h, *data.exact_u2, VectorTools::L2_norm);
    totals.final_error = std::sqrt(l1 * l1 + l2 * l2);
  }


  namespace
  {
    // The terms of a step estimate in summary.json, by their keys.
    const std::pair<const char *, double StepEstimate::*> step_terms[] = {
      {"eta", &StepEstimate::eta},
      {"eta_disc", &StepEstimate::eta_disc},
      {"eta_lin", &StepEstimate::eta_lin},
      {"eta_alg", &StepEstimate::eta_alg},
      {"eta_time", &StepEstimate::eta_time},
      {"eta_space", &StepEstimate::eta_space},
      {"oscillation", &StepEstimate::oscillation},
      {"eta_dt", &StepEstimate::eta_dt},
      {"nonc_squared", &StepEstimate::nonc_squared},
      {"final_nonc", &StepEstimate::final_nonc},
      {"eta_l2", &StepEstimate::eta_l2},
      {"change_of_d", &StepEstimate::change},
    };

    // Which of the second bound's variants the bound is (0: none, else
    // v + 1, StepEstimate::eta_variant): the membrane whose load it takes
    // in L2 (0: none) and where it takes the multiplier's non-conforming
    // part.
    void
    describe_variant(const unsigned int which, VI::Json &json)
    {
      json["load_in_l2_of_membrane"] = which == 0 ? 0u : (which - 1) / 2 + 1;
      json["nonconforming_multiplier_in"] =
        which > 0 && (which - 1) % 2 == 1 ? "L2" : "H^-1";
    }


    VI::Json
    to_json(const StepEstimate &e)
    {
      VI::Json json = VI::Json::object();
      for (const auto &[key, term] : step_terms)
        json[key] = e.*term;
      // The steady estimators at t_n.
      json["flux_disc_end"] = e.at_end.flux_disc;
      json["residual_end"]  = e.at_end.residual;
      json["contact_end"]   = e.at_end.contact_cone;
      // The second bound's variants (StepEstimate::eta_variant).
      VI::Json eta_variant = VI::Json::array(), l2_variant = VI::Json::array();
      for (unsigned int v = 0; v < e.eta_variant.size(); ++v)
        {
          eta_variant.push_back(e.eta_variant[v]);
          l2_variant.push_back(e.l2_variant[v]);
        }
      json["eta_variant"] = eta_variant;
      json["l2_variant"]  = l2_variant;
      return json;
    }
  } // namespace


  template <int dim>
  void
  ParabolicProblem<dim>::record_step(const double wall_seconds)
  {
    StepRecord r;
    r.step     = step;
    r.time     = time;
    r.dt       = time_step;
    r.newton   = newton_this_step;
    r.linear   = linear_this_step;
    r.rejected = rejected_this_step;
    r.contact  = n_contact_nodes;
    if (final_estimate)
      {
        r.eta_step = final_estimate->eta;
        r.eta_time = final_estimate->eta_time;
        r.eta      = totals.eta();
      }
    if (data.has_exact_solution())
      {
        r.error = totals.error();
        if (final_estimate)
          r.effectivity = r.eta / r.error;
      }
    records.push_back(r);

    VI::Json json = VI::Json::object({{"step", step},
                                      {"time", time},
                                      {"dt", time_step},
                                      {"rejected", rejected_this_step},
                                      {"newton_iterations", newton_this_step},
                                      {"linear_iterations", linear_this_step},
                                      {"contact_nodes", n_contact_nodes}});
    if (!contact_per_ring.empty())
      {
        VI::Json rings = VI::Json::array();
        for (const auto n : contact_per_ring)
          rings.push_back(n);
        json["contact_nodes_per_ring"] = rings;
      }
    if (final_estimate)
      {
        json["estimate"]       = to_json(*final_estimate);
        json["eta"]            = totals.eta();
        json["eta_init"]       = totals.eta_init;
        json["eta_disc_total"] = totals.eta_disc();
        json["eta_lin_total"]  = totals.eta_lin();
        json["eta_alg_total"]  = totals.eta_alg();
        json["time_derivative_of_d_in"] =
          totals.l2_bound_is_smaller() || totals.smallest_variant() > 0 ?
            "L2" :
            "H^-1";
        describe_variant(totals.smallest_variant(), json);
      }
    if (data.has_exact_solution())
      {
        json["error_energy"] = step_error_energy;
        json["error_l2"]     = totals.final_error;
        json["error"]        = totals.error();
        if (final_estimate)
          json["effectivity"] = totals.eta() / totals.error();
      }
    json["wall_seconds"] = wall_seconds;
    json["newton_steps"] = VI::newton_steps(newton_report);
    json["iterations"]   = VI::to_json(stopping.records, false);
    std::ostringstream text;
    json.write(text, 4);
    step_json.push_back(text.str());
    run_record.add(VI::Json::raw(text.str()));
  }


  template <int dim>
  void
  ParabolicProblem<dim>::output_results()
  {
    if (!parameters.output.write_vtu)
      return;
    TimerOutput::Scope t(timer, "output");

    // The indicators of the estimate at the end of the step, t_n.
    VI::FieldOutput<dim> output = solution_output();
    output.add_indicators(final_estimate ? &final_estimate->at_end : nullptr);
    vtu_files.emplace_back(
      time, output.write(parameters.output.directory, step, 5, comm, time));
    if (Utilities::MPI::this_mpi_process(comm) == 0)
      {
        std::ofstream pvd(parameters.output.directory + "/solution.pvd");
        DataOutBase::write_pvd_record(pvd, vtu_files);
      }
  }


  // The table of the steps, to the screen (the last rows) and to
  // convergence.txt, with the totals below it.
  template <int dim>
  void
  ParabolicProblem<dim>::write_tables() const
  {
    ConvergenceTable table;
    const bool       estimate = parameters.estimators.enabled;
    const bool       exact    = data.has_exact_solution();
    for (const StepRecord &r : records)
      {
        table.add_value("step", r.step);
        table.add_value("time", r.time);
        table.add_value("dt", r.dt);
        table.add_value("newton", r.newton);
        table.add_value("linear", r.linear);
        table.add_value("contact", r.contact);
        if (parameters.time.adaptive)
          table.add_value("rejected", r.rejected);
        if (estimate)
          {
            table.add_value("eta_time", r.eta_time);
            table.add_value("eta_n", r.eta_step);
            table.add_value("eta", r.eta);
          }
        if (exact)
          {
            table.add_value("error", r.error);
            if (estimate)
              table.add_value("effectivity", r.effectivity);
          }
      }
    table.set_precision("time", 6);
    table.set_precision("dt", 4);
    table.set_scientific("dt", true);
    for (const std::string key : {"eta_time", "eta_n", "eta", "error"})
      {
        table.set_precision(key, 4);
        table.set_scientific(key, true);
      }
    table.set_precision("effectivity", 4);

    std::ostringstream totals_text;
    totals_text << "# steps " << records.size() << ", rejected "
                << totals.rejected << "; cumulative Newton " << totals.newton
                << ", linear " << totals.linear << "\n";
    if (estimate)
      totals_text << std::scientific << std::setprecision(4) << "# eta "
                  << totals.eta() << " <= eta_init " << totals.eta_init
                  << " + eta_disc " << totals.eta_disc() << " + eta_lin "
                  << totals.eta_lin() << " + eta_alg " << totals.eta_alg()
                  << "\n";
    if (exact)
      totals_text << std::scientific << std::setprecision(4) << "# error "
                  << totals.error() << std::defaultfloat
                  << (estimate ? ", effectivity " : "")
                  << (estimate ? std::to_string(totals.eta() / totals.error()) :
                                 "")
                  << "\n";

    if (Utilities::MPI::this_mpi_process(comm) == 0)
      {
        std::ofstream file(parameters.output.directory + "/convergence.txt");
        table.write_text(file, TableHandler::org_mode_table);
        file << totals_text.str();
        pcout << std::endl << totals_text.str();
      }
  }


  template <int dim>
  void
  ParabolicProblem<dim>::add_totals(VI::Json &summary) const
  {
    VI::Json total             = VI::Json::object();
    total["steps"]             = records.size();
    total["time"]              = time;
    total["rejected_steps"]    = totals.rejected;
    total["newton_iterations"] = totals.newton;
    total["linear_iterations"] = totals.linear;
    if (parameters.estimators.enabled)
      {
        total["eta"]      = totals.eta();
        total["eta_init"] = totals.eta_init;
        total["eta_disc"] = totals.eta_disc();
        total["eta_lin"]  = totals.eta_lin();
        total["eta_alg"]  = totals.eta_alg();
        total["time_derivative_of_d_in"] =
          totals.l2_bound_is_smaller() || totals.smallest_variant() > 0 ?
            "L2" :
            "H^-1";
        describe_variant(totals.smallest_variant(), total);
      }
    if (data.has_exact_solution() && !records.empty())
      {
        total["error"] = totals.error();
        if (parameters.estimators.enabled)
          total["effectivity"] = totals.eta() / totals.error();
      }
    summary["totals"] = total;
  }


  // Explicit instantiations of this file's members.
  template void
  ParabolicProblem<2>::postprocess();
  template void
  ParabolicProblem<2>::compute_errors();
  template void
  ParabolicProblem<2>::record_step(const double wall_seconds);
  template void
  ParabolicProblem<2>::output_results();
  template void
  ParabolicProblem<2>::write_tables() const;
  template void
  ParabolicProblem<2>::add_totals(VI::Json &summary) const;
} // namespace StepParabolic
