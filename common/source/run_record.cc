#include <deal.II/base/conditional_ostream.h>
#include <deal.II/base/convergence_table.h>
#include <deal.II/base/parameter_handler.h>

#include <vi/errors.h>
#include <vi/parameters.h>
#include <vi/process_usage.h>
#include <vi/program.h>
#include <vi/run_record.h>
#include <vi/timer_summary.h>

#include <fstream>
#include <iomanip>
#include <iostream>
#include <sstream>

namespace VI
{
  using namespace dealii;


  std::string
  describe_solvers(const NonlinearSolverParameters &nonlinear,
                   const LinearSolverParameters    &linear)
  {
    return "(" + to_string(nonlinear.strategy) + ")" +
           (nonlinear.nested_iteration ? " with" : " without") +
           " nested iteration, " +
           (linear.solver == LinearSolverType::direct ?
              "direct solver " + linear.direct_package :
              "GMRES + " + to_string(linear.preconditioner));
  }


  std::string
  counted_linear_solver(const LinearSolverParameters &linear)
  {
    return linear.solver == LinearSolverType::gmres ? "GMRES" : "";
  }


  RunRecord::RunRecord(const std::string &program,
                       const std::string &output_directory,
                       TimerOutput       &timer,
                       const MPI_Comm     comm)
      : program(program)
      , directory(output_directory)
      , timer(timer)
      , comm(comm)
  {
  }


  void
  RunRecord::start(ParameterHandler  &prm,
                   const std::string &description,
                   const std::string &list_key)
  {
    if (Utilities::MPI::this_mpi_process(comm) == 0)
      std::cout << run_header(program, comm) << '\n'
                << description << std::endl;
    prepare_output_directory(directory, comm);
    list          = list_key;
    summary       = make_summary(program, comm, prm);
    summary[list] = Json::array();
  }


  void
  RunRecord::guard(const std::function<void()> &solve)
  {
    try
      {
        solve();
      }
    catch (const SolverFailure &failure)
      {
        // Keep what the completed cycles measured, marked as failed.
        summary["status"]  = "failed";
        summary["failure"] = std::string(failure.what());
        write();
        throw;
      }
  }


  void
  RunRecord::start_cycle()
  {
    cycle_timer.restart();
    timing_at_cycle_start.clear();
    for (const auto &[section, seconds] :
         timer.get_summary_data(TimerOutput::total_wall_time))
      timing_at_cycle_start[section] = seconds;
  }


  void
  RunRecord::stop_cycle()
  {
    cycle_timer.stop();
  }


  double
  RunRecord::cycle_seconds() const
  {
    return cycle_timer.wall_time();
  }


  Json
  RunRecord::cycle_timing() const
  {
    Json timing = Json::object();
    for (const auto &[section, seconds] :
         timer.get_summary_data(TimerOutput::total_wall_time))
      {
        const auto before = timing_at_cycle_start.find(section);
        timing[section] =
          seconds -
          (before == timing_at_cycle_start.end() ? 0. : before->second);
      }
    return timing;
  }


  void
  RunRecord::add(const Json &record)
  {
    summary[list].push_back(record);
  }


  std::vector<std::string>
  ErrorColumns::rate_keys() const
  {
    std::vector<std::string> keys;
    if (energy)
      keys.push_back("error_energy");
    if (energy && multiplier)
      keys.push_back("error_lambda");
    if (estimate)
      keys.push_back("eta");
    return keys;
  }


  void
  RunRecord::write_tables(const ConvergenceTable         &table,
                          const std::vector<std::string> &counts,
                          const ErrorColumns             &errors,
                          const std::vector<std::string> &more,
                          const unsigned int              dim) const
  {
    ConvergenceTable with_rates = table;
    for (const std::string &key : errors.rate_keys())
      with_rates.evaluate_convergence_rates(
        key, "dofs", ConvergenceTable::reduction_rate_log2, dim);
    if (Utilities::MPI::this_mpi_process(comm) != 0)
      return;
    std::cout << std::endl;
    with_rates.write_text(std::cout, TableHandler::org_mode_table);

    std::vector<std::string> columns = counts;
    for (const std::string &key : errors.rate_keys())
      columns.push_back(key);
    if (errors.energy && errors.estimate)
      columns.push_back("effectivity");
    columns.insert(columns.end(), more.begin(), more.end());
    std::ofstream    file(directory + "/convergence.txt");
    ConvergenceTable file_table = with_rates;
    file_table.set_column_order(columns);
    file_table.write_text(file, TableHandler::org_mode_table);
  }


  void
  RunRecord::finish(const std::string &files, const std::string &status)
  {
    summary["status"]              = status;
    summary["peak_resident_bytes"] = peak_resident_bytes(comm);
    write();
    if (Utilities::MPI::this_mpi_process(comm) == 0)
      std::cout << "\nOutput in " << directory << "/: " << files << std::endl;
  }


  void
  RunRecord::write()
  {
    if (complete_summary)
      complete_summary(summary);
    summary["timing"] = section_wall_times(timer);
    write_summary(summary, directory, comm);
  }


  std::string
  to_string(const CycleNumbers &numbers)
  {
    std::ostringstream out;
    out << "   " << numbers.solver << ": " << numbers.newton_iterations
        << " iterations";
    if (!numbers.linear_solver.empty())
      out << ", " << numbers.linear_iterations << ' ' << numbers.linear_solver;
    out << ", " << numbers.contact_nodes << " nodes in contact";
    const auto &error = numbers.error_energy;
    if (error)
      out << ", energy error " << std::scientific << std::setprecision(3)
          << *error << std::defaultfloat;
    if (numbers.estimate)
      {
        out << ", estimate " << std::scientific << std::setprecision(3)
            << *numbers.estimate << std::defaultfloat;
        if (error)
          out << " (effectivity " << std::setprecision(3)
              << *numbers.estimate / *error << ")";
      }
    out << ", " << std::setprecision(3) << numbers.seconds << " s";
    return out.str();
  }


  void
  CycleNumbers::set_solve(const std::string  &solver,
                          const NewtonReport &report,
                          const std::string  &linear_solver,
                          unsigned long long  contact_nodes)
  {
    this->solver        = solver;
    newton_iterations   = report.iterations;
    linear_iterations   = report.linear_iterations;
    this->linear_solver = linear_solver;
    this->contact_nodes = contact_nodes;
  }


  void
  add_columns(ConvergenceTable &table, const CycleNumbers &numbers)
  {
    table.add_value("cycle", numbers.cycle);
    table.add_value("cells", numbers.cells);
    table.add_value("dofs", numbers.dofs);
    if (numbers.dofs_condensed)
      table.add_value("dofs_condensed", *numbers.dofs_condensed);
    table.add_value("newton", numbers.newton_iterations);
    table.add_value("linear", numbers.linear_iterations);
    table.add_value("contact", numbers.contact_nodes);
    // The errors and the estimate in four significant digits.
    const auto scientific = [&](const std::string &key, const double value) {
      table.add_value(key, value);
      table.set_scientific(key, true);
      table.set_precision(key, 4);
    };
    const auto &error = numbers.error_energy;
    if (error)
      {
        scientific("error_energy", *error);
        if (numbers.error_multiplier)
          scientific("error_lambda", *numbers.error_multiplier);
      }
    if (numbers.estimate)
      {
        scientific("eta", *numbers.estimate);
        if (error)
          {
            table.add_value("effectivity", *numbers.estimate / *error);
            table.set_precision("effectivity", 3);
          }
      }
    table.add_value("wall_s", numbers.seconds);
    table.set_precision("wall_s", 3);
  }


  Json
  to_json(const CycleNumbers &numbers)
  {
    Json record                 = Json::object();
    record["cycle"]             = numbers.cycle;
    record["cells"]             = numbers.cells;
    record["newton_iterations"] = numbers.newton_iterations;
    record["linear_iterations"] = numbers.linear_iterations;
    record["contact_nodes"]     = numbers.contact_nodes;
    if (numbers.error_energy)
      record["error_energy"] = *numbers.error_energy;
    if (numbers.error_multiplier)
      record["error_lambda_l2"] = *numbers.error_multiplier;
    if (numbers.estimate)
      {
        record["eta"] = *numbers.estimate;
        if (numbers.error_energy)
          record["effectivity"] = *numbers.estimate / *numbers.error_energy;
      }
    record["wall_seconds"] = numbers.seconds;
    return record;
  }
} // namespace VI
