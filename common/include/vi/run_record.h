#pragma once

#include <deal.II/base/mpi.h>
#include <deal.II/base/timer.h>

#include <vi/summary.h>

#include <functional>
#include <map>
#include <optional>
#include <string>
#include <vector>

namespace dealii
{
  class ConvergenceTable;
  class ParameterHandler;
} // namespace dealii

namespace VI
{
  /**
   * What every run of a program records around its algorithm, so that the
   * programs' run() read like the algorithm:
   *
   * - start(): the run header (program, version, deal.II, ranks, threads)
   *   and the line that says what is solved; summary.json begun with the
   *   program, its versions and parameters, and an empty list of cycles
   *   (or time steps);
   * - guard(): a solve whose failure writes summary.json as it stands,
   *   marked "status": "failed" with the reason, before it propagates
   *   (run_program() turns it into one line and exit status 2);
   * - start_cycle() / cycle_timing(): the wall time of a cycle and its share
   *   of every TimerOutput section;
   * - finish(): "status": "converged", the total of every TimerOutput
   *   section, summary.json, and the closing line that says where the
   *   output is.
   */
  class RunRecord
  {
  public:
    RunRecord(const std::string   &program,
              const std::string   &output_directory,
              dealii::TimerOutput &timer,
              const MPI_Comm       comm);

    /// `list`: the key of the records of the run ("cycles", "steps").
    void
    start(dealii::ParameterHandler &prm,
          const std::string        &description,
          const std::string        &list = "cycles");

    /// Run `solve`; on SolverFailure write the summary marked as failed.
    void
    guard(const std::function<void()> &solve);

    /// Restart the cycle's wall clock and remember the timer's sections.
    void
    start_cycle();

    /// Stop the cycle's wall clock (what follows is not the cycle's).
    void
    stop_cycle();

    /// The wall time of the cycle (up to stop_cycle()).
    double
    cycle_seconds() const;

    /// This cycle's share of every TimerOutput section.
    Json
    cycle_timing() const;

    /// Append a cycle's record to the summary's list.
    void
    add(const Json &record);

    /**
     * The convergence table with the rates of the columns `rate_keys` in h
     * (from the column "dofs", in `dim` dimensions): on the screen with
     * every column (wall times too), and in convergence.txt with
     * `file_columns` only, so that the file is reproducible and diffable
     * (the tests compare it). An error key names the supercolumn of the
     * error and its rate.
     */
    void
    write_tables(const dealii::ConvergenceTable &table,
                 const std::vector<std::string> &rate_keys,
                 const std::vector<std::string> &file_columns,
                 const unsigned int              dim = 2) const;

    /// `files`: what the output directory holds, for the closing line.
    void
    finish(const std::string &files);

    /// The summary as it will be written (programs add their own keys).
    Json summary;

  private:
    const std::string             program;
    const std::string             directory;
    dealii::TimerOutput          &timer;
    const MPI_Comm                comm;
    std::string                   list;
    dealii::Timer                 cycle_timer;
    std::map<std::string, double> timing_at_cycle_start;
  };


  /**
   * The line a program prints after each cycle:
   *   "   <solver>: <n> iterations, <m> <linear solver>, <c> nodes in
   *    contact, energy error <e>, estimate <eta> (effectivity <eta/e>), <t> s"
   * with the parts that are known.
   */
  struct CycleLine
  {
    std::string  solver;
    unsigned int newton_iterations = 0;
    /// Iterations of the linear solver and its name ("GMRES"); no part if
    /// the name is empty.
    unsigned int          linear_iterations = 0;
    std::string           linear_solver;
    unsigned long long    contact_nodes = 0;
    std::optional<double> error, estimate;
    double                seconds = 0;
  };

  std::string
  to_string(const CycleLine &line);
} // namespace VI
