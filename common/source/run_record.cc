#include <deal.II/base/conditional_ostream.h>
#include <deal.II/base/convergence_table.h>
#include <deal.II/base/parameter_handler.h>

#include <vi/errors.h>
#include <vi/program.h>
#include <vi/run_record.h>

#include <fstream>
#include <iomanip>
#include <iostream>
#include <sstream>

namespace VI
{
  using namespace dealii;


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
        write_summary(summary, directory, comm);
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


  void
  RunRecord::write_tables(const ConvergenceTable         &table,
                          const std::vector<std::string> &rate_keys,
                          const std::vector<std::string> &file_columns,
                          const unsigned int              dim) const
  {
    ConvergenceTable with_rates = table;
    for (const std::string &key : rate_keys)
      with_rates.evaluate_convergence_rates(
        key, "dofs", ConvergenceTable::reduction_rate_log2, dim);
    if (Utilities::MPI::this_mpi_process(comm) != 0)
      return;
    std::cout << std::endl;
    with_rates.write_text(std::cout, TableHandler::org_mode_table);
    std::ofstream    file(directory + "/convergence.txt");
    ConvergenceTable file_table = with_rates;
    file_table.set_column_order(file_columns);
    file_table.write_text(file, TableHandler::org_mode_table);
  }


  void
  RunRecord::finish(const std::string &files)
  {
    summary["status"] = "converged";
    summary["timing"] = Json::object();
    for (const auto &[section, seconds] :
         timer.get_summary_data(TimerOutput::total_wall_time))
      summary["timing"][section] = seconds;
    write_summary(summary, directory, comm);
    if (Utilities::MPI::this_mpi_process(comm) == 0)
      std::cout << "\nOutput in " << directory << "/: " << files << std::endl;
  }


  std::string
  to_string(const CycleLine &line)
  {
    std::ostringstream out;
    out << "   " << line.solver << ": " << line.newton_iterations
        << " iterations";
    if (!line.linear_solver.empty())
      out << ", " << line.linear_iterations << ' ' << line.linear_solver;
    out << ", " << line.contact_nodes << " nodes in contact";
    if (line.error)
      out << ", energy error " << std::scientific << std::setprecision(3)
          << *line.error << std::defaultfloat;
    if (line.estimate)
      {
        out << ", estimate " << std::scientific << std::setprecision(3)
            << *line.estimate << std::defaultfloat;
        if (line.error)
          out << " (effectivity " << std::setprecision(3)
              << *line.estimate / *line.error << ")";
      }
    out << ", " << std::setprecision(3) << line.seconds << " s";
    return out.str();
  }
} // namespace VI
