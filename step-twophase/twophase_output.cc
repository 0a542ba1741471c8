// Output of step-twophase: the profiles and VTU files at the output times,
// the tables of the run (convergence.txt, x0.csv) and summary.json.

#include <deal.II/base/table_handler.h>
#include <deal.II/numerics/data_out.h>

#include <vi/summary.h>

#include "twophase_problem.h"

#include <array>
#include <fstream>
#include <iomanip>
#include <map>
#include <sstream>

namespace StepTwoPhase
{
  /**
   * At an output time: solution-NNN.vtu (cell values of S, S_g, P_l, P_g,
   * chi, the estimators' cell indicators, and the conforming P2
   * reconstructions of P_l, P_g, chi), the solution.pvd index, and
   * profile-NNN.csv with the cell values.
   */
  void
  TwoPhaseProblem::output_results()
  {
    TimerOutput::Scope t(timer, "output");
    const unsigned int index = next_output++;
    const unsigned int N     = scheme->n_cells();
    const std::string &dir   = parameters.output.directory;
    std::ostringstream number;
    number << std::setw(3) << std::setfill('0') << index;

    {
      std::ofstream csv(dir + "/profile-" + number.str() + ".csv");
      csv << "time_years,x,S_l,S_g,P_l,P_g,chi,eta_flux,eta_nonconformity,"
             "eta_phase_transition\n"
          << std::setprecision(10);
      for (unsigned int K = 0; K < N; ++K)
        {
          const CellState U = scheme->state(solution, K);
          csv << years(time) << ',' << scheme->cell_center(K) << ',' << U.S
              << ',' << 1. - U.S << ',' << U.P << ','
              << U.P + model.capillary_pressure(U.S).value << ',' << U.chi
              << ',' << estimators->flux_indicators()[K] << ','
              << estimators->nonconformity_indicators()[K] << ','
              << years(estimators->phase_transition_indicators()[K]) << '\n';
        }
    }

    if (!parameters.output.write_vtu)
      return;
    std::map<std::string, Vector<double>> cell_fields;
    for (const char *name : {"S_l",
                             "S_g",
                             "P_l",
                             "P_g",
                             "chi",
                             "eta_flux",
                             "eta_nonconformity",
                             "eta_phase_transition"})
      cell_fields[name].reinit(triangulation.n_active_cells());
    for (unsigned int K = 0; K < N; ++K)
      {
        const CellState    U       = scheme->state(solution, K);
        const unsigned int c       = cell_of[K];
        cell_fields["S_l"][c]      = U.S;
        cell_fields["S_g"][c]      = 1. - U.S;
        cell_fields["P_l"][c]      = U.P;
        cell_fields["P_g"][c]      = U.P + model.capillary_pressure(U.S).value;
        cell_fields["chi"][c]      = U.chi;
        cell_fields["eta_flux"][c] = estimators->flux_indicators()[K];
        cell_fields["eta_nonconformity"][c] =
          estimators->nonconformity_indicators()[K];
        cell_fields["eta_phase_transition"][c] =
          years(estimators->phase_transition_indicators()[K]);
      }

    // The reconstructions P_tilde^l, P_tilde^g, chi_tilde as FE_Q(2)
    // functions (continuous: Oswald averaging made the vertex values agree).
    std::array<Vector<double>, 3>        reconstructions;
    std::vector<types::global_dof_index> dofs(
      reconstruction_fe.n_dofs_per_cell());
    std::vector<unsigned int> K_of(triangulation.n_active_cells());
    for (unsigned int K = 0; K < N; ++K)
      K_of[cell_of[K]] = K;
    const std::array<const Estimators::Field *, 3> fields = {
      {&estimators->reconstructed_liquid_pressure(),
       &estimators->reconstructed_gas_pressure(),
       &estimators->reconstructed_molar_fraction()}};
    for (unsigned int f = 0; f < 3; ++f)
      reconstructions[f].reinit(reconstruction_dof_handler.n_dofs());
    for (const auto &cell : reconstruction_dof_handler.active_cell_iterators())
      {
        cell->get_dof_indices(dofs);
        const unsigned int K = K_of[cell->active_cell_index()];
        for (unsigned int f = 0; f < 3; ++f)
          for (unsigned int i = 0; i < 3; ++i)
            reconstructions[f][dofs[i]] = fields[f]->conforming[K][i];
      }

    DataOut<1> data_out;
    data_out.attach_dof_handler(reconstruction_dof_handler);
    data_out.add_data_vector(reconstructions[0], "P_l_reconstructed");
    data_out.add_data_vector(reconstructions[1], "P_g_reconstructed");
    data_out.add_data_vector(reconstructions[2], "chi_reconstructed");
    for (const auto &[name, values] : cell_fields)
      data_out.add_data_vector(values, name, DataOut<1>::type_cell_data);
    data_out.build_patches(2);
    DataOutBase::VtkFlags flags(years(time));
    flags.compression_level = DataOutBase::VtkFlags::best_speed;
    flags.physical_units    = {{"P_l", "Pa"},
                               {"P_g", "Pa"},
                               {"P_l_reconstructed", "Pa"},
                               {"P_g_reconstructed", "Pa"},
                               {"eta_phase_transition", "m yr"}};
    data_out.set_flags(flags);
    const std::string file = "solution-" + number.str() + ".vtu";
    std::ofstream     vtu(dir + "/" + file);
    data_out.write_vtu(vtu);
    vtu_files.emplace_back(years(time), file);
    std::ofstream pvd(dir + "/solution.pvd");
    DataOutBase::write_pvd_record(pvd, vtu_files);
  }


  namespace
  {
    /// The state at x = 0 of a step: its column in convergence.txt and its
    /// key in summary.json.
    struct AtOrigin
    {
      const char *column, *key;
      double StepRecord::*value;
    };
    const AtOrigin at_origin[] = {
      {"S_g(0)", "gas_saturation_x0", &StepRecord::gas_saturation_x0},
      {"P_l(0)", "liquid_pressure_x0", &StepRecord::liquid_pressure_x0},
      {"P_g(0)", "gas_pressure_x0", &StepRecord::gas_pressure_x0},
      {"chi(0)", "molar_fraction_x0", &StepRecord::molar_fraction_x0},
    };
  } // namespace


  /**
   * convergence.txt: one row per step with everything deterministic (no
   * timings), diffed by the tests; x0.csv: the time series at x = 0.
   */
  void
  TwoPhaseProblem::write_tables() const
  {
    const bool adaptive =
      parameters.nonlinear_solver.strategy == VI::Strategy::adaptive;
    TableHandler table;
    for (const StepRecord &r : records)
      {
        table.add_value("step", r.step);
        table.add_value("t_yr", years(r.time));
        table.add_value("dt_yr", years(r.dt));
        table.add_value("newton", r.newton);
        table.add_value("gmres", r.linear);
        table.add_value("cuts", r.cuts);
        for (const AtOrigin &q : at_origin)
          table.add_value(q.column, r.*q.value);
        table.add_value("front_m", r.gas_front);
        table.add_value("eta_disc", r.eta.disc);
        if (adaptive)
          {
            table.add_value("eta_lin", r.eta.lin);
            table.add_value("eta_alg", r.eta.alg);
          }
        table.add_value("eta_C", years(r.eta.phase_transition));
      }
    for (const char *column : {"t_yr", "dt_yr"})
      table.set_precision(column, 8);
    for (const char *column :
         {"S_g(0)", "P_l(0)", "P_g(0)", "chi(0)", "eta_disc", "eta_C"})
      {
        table.set_scientific(column, true);
        table.set_precision(column, 8);
      }
    if (adaptive)
      for (const char *column : {"eta_lin", "eta_alg"})
        {
          table.set_scientific(column, true);
          table.set_precision(column, 8);
        }
    table.set_precision("front_m", 6);
    std::ofstream file(parameters.output.directory + "/convergence.txt");
    table.write_text(file, TableHandler::org_mode_table);

    std::ofstream csv(parameters.output.directory + "/x0.csv");
    csv << "time_years,dt_years,S_g,P_l,P_g,chi,gas_front_m,newton,gmres,"
           "cuts\n"
        << std::setprecision(10);
    for (const StepRecord &r : records)
      csv << years(r.time) << ',' << years(r.dt) << ',' << r.gas_saturation_x0
          << ',' << r.liquid_pressure_x0 << ',' << r.gas_pressure_x0 << ','
          << r.molar_fraction_x0 << ',' << r.gas_front << ',' << r.newton << ','
          << r.linear << ',' << r.cuts << '\n';
  }


  void
  TwoPhaseProblem::add_results(VI::Json &summary) const
  {
    summary["time_unit"] = "year";
    summary["cells"]     = scheme->n_cells();
    summary["unknowns"]  = scheme->n_unknowns();

    unsigned int newton = 0, linear = 0, rejected_newton = 0,
                 rejected_linear = 0;
    VI::Json steps               = VI::Json::array();
    for (const StepRecord &r : records)
      {
        newton += r.newton;
        linear += r.linear;
        rejected_newton += r.rejected_newton;
        rejected_linear += r.rejected_linear;
        VI::Json s                      = VI::Json::object();
        s["step"]                       = r.step;
        s["time"]                       = years(r.time);
        s["dt"]                         = years(r.dt);
        s["newton_iterations"]          = r.newton;
        s["linear_iterations"]          = r.linear;
        s["time_step_cuts"]             = r.cuts;
        s["rejected_newton_iterations"] = r.rejected_newton;
        s["rejected_linear_iterations"] = r.rejected_linear;
        for (const AtOrigin &q : at_origin)
          s[q.key] = r.*q.value;
        s["gas_front"]            = r.gas_front;
        s["eta_disc"]             = r.eta.disc;
        s["eta_lin"]              = r.eta.lin;
        s["eta_alg"]              = r.eta.alg;
        s["eta_flux"]             = r.eta.flux;
        s["eta_nonconformity"]    = r.eta.nonconformity;
        s["eta_equilibrium"]      = r.eta.equilibrium;
        s["eta_phase_transition"] = years(r.eta.phase_transition);
        s["wall_seconds"]         = r.wall_seconds;
        VI::Json iterations       = VI::Json::array();
        for (const IterationRecord &it : r.iterations)
          {
            VI::Json i                    = VI::Json::object();
            i["k"]                        = it.k;
            i["i"]                        = it.i;
            i["residual_equations"]       = it.residual.equations;
            i["residual_complementarity"] = it.residual.complementarity;
            i["step_length"]              = it.step_length;
            if (parameters.nonlinear_solver.strategy == VI::Strategy::adaptive)
              {
                i["eta_disc"] = it.eta.disc;
                i["eta_lin"]  = it.eta.lin;
                i["eta_alg"]  = it.eta.alg;
              }
            iterations.push_back(i);
          }
        s["iterations"] = iterations;
        steps.push_back(s);
      }
    summary["steps"] = steps;

    VI::Json cut_log = VI::Json::array();
    for (const TimeStepCut &c : cuts)
      {
        VI::Json entry  = VI::Json::object();
        entry["time"]   = years(c.time);
        entry["dt"]     = years(c.dt);
        entry["reason"] = c.reason;
        cut_log.push_back(entry);
      }
    summary["time_step_cuts"] = cut_log;

    VI::Json totals                      = VI::Json::object();
    totals["steps"]                      = records.size();
    totals["newton_iterations"]          = newton;
    totals["linear_iterations"]          = linear;
    totals["rejected_newton_iterations"] = rejected_newton;
    totals["rejected_linear_iterations"] = rejected_linear;
    totals["time_step_cuts"]             = cuts.size();
    totals["wall_seconds"]               = run_timer.wall_time();
    summary["totals"]                    = totals;
  }
} // namespace StepTwoPhase
