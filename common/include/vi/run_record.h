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
  struct NonlinearSolverParameters;
  struct LinearSolverParameters;

  /**
   * How a membrane program solves its contact system, for the line that
   * says what a run does: "(<strategy>) with[out] nested iteration, direct
   * solver <package>" or "..., GMRES + <preconditioner>".
   */
  std::string
  describe_solvers(const NonlinearSolverParameters &nonlinear,
                   const LinearSolverParameters    &linear);

  /// The linear solver whose iterations the progress line counts: "GMRES",
  /// or none for the direct solver.
  std::string
  counted_linear_solver(const LinearSolverParameters &linear);

  /**
   * The errors and the estimate a run tabulates, known before it starts:
   * their columns in convergence.txt and the rates shown on the screen.
   */
  struct ErrorColumns
  {
    /// "error_energy": the exact solution is known.
    bool energy = false;
    /// "error_lambda": the exact multiplier is known as well.
    bool multiplier = false;
    /// "eta", and "effectivity" with the energy error.
    bool estimate = false;

    /// The columns whose rates are shown.
    std::vector<std::string>
    rate_keys() const;
  };


  /**
   * What every run of a program records around its algorithm, so that the
   * programs' run() read like the algorithm:
   *
   * - start(): the run header (program, version, deal.II, ranks, threads)
   *   and the line that says what is solved; summary.json begun with the
   *   program, its versions and parameters, and an empty list of cycles
   *   (or time steps); the output directory made (or the run stopped
   *   with one line if it cannot be written);
   * - guard(): a solve whose failure writes summary.json as it stands
   *   (with the timing so far), marked "status": "failed" with the
   *   reason, before it propagates (run_program() turns it into one line
   *   and exit status 2);
   * - start_cycle() / cycle_timing(): the wall time of a cycle and its share
   *   of every TimerOutput section;
   * - finish(): the status ("converged"), the total of every TimerOutput
   *   section, summary.json, and the closing line that says where the
   *   output is.
   *
   * A time-dependent program records its steps the same way (`list`
   * "steps", one record per step, the status "completed" or "stopped").
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
     * The convergence table: on the screen with every column (wall times
     * too) and the rates of `errors` in h (from the column "dofs", in `dim`
     * dimensions); in convergence.txt with the columns `counts`, the errors
     * and `more` only, so that the file is reproducible and diffable (the
     * tests compare it).
     */
    void
    write_tables(const dealii::ConvergenceTable &table,
                 const std::vector<std::string> &counts,
                 const ErrorColumns             &errors,
                 const std::vector<std::string> &more = {},
                 const unsigned int              dim  = 2) const;

    /// `files`: what the output directory holds, for the closing line;
    /// `status`: how the run ended ("converged"; a time-dependent run
    /// "completed" at the final time or "stopped" to be resumed).
    void
    finish(const std::string &files, const std::string &status = "converged");

    /// What the program adds to the summary just before it is written, at
    /// the end or on a failure (totals, say); optional.
    std::function<void(Json &summary)> complete_summary;

    /// The summary as it will be written (programs add their own keys).
    Json summary;

  private:
    /// The summary completed, with the timing of every section, written.
    void
    write();

    const std::string             program;
    const std::string             directory;
    dealii::TimerOutput          &timer;
    const MPI_Comm                comm;
    std::string                   list;
    dealii::Timer                 cycle_timer;
    std::map<std::string, double> timing_at_cycle_start;
  };


  /**
   * What a cycle of a stationary program measures, and the three places it
   * goes: the line printed after the cycle (to_string()), the columns of
   * the convergence table (add_columns()) and the keys of the cycle's
   * record in summary.json (to_json()). The programs add what is their own.
   */
  struct CycleNumbers
  {
    CycleNumbers() = default;
    /// Cycle `cycle` on a mesh of `cells` cells, `dofs` in the column
    /// "dofs", that took `seconds`.
    CycleNumbers(const unsigned int       cycle,
                 const unsigned long long cells,
                 const unsigned long long dofs,
                 const double             seconds)
        : cycle(cycle)
        , cells(cells)
        , dofs(dofs)
        , seconds(seconds)
    {
    }

    unsigned int       cycle = 0;
    unsigned long long cells = 0;
    /// The column "dofs" of the table, from which rates in h are computed.
    unsigned long long dofs = 0;
    /// The unknowns after static condensation (HHO), a column beside it.
    std::optional<unsigned long long> dofs_condensed;
    /// The nonlinear solver ("Newton-min").
    std::string  solver;
    unsigned int newton_iterations = 0;
    /// Iterations of the linear solver and its name ("GMRES"); the progress
    /// line names them only if the name is given.
    unsigned int          linear_iterations = 0;
    std::string           linear_solver;
    unsigned long long    contact_nodes = 0;
    std::optional<double> error_energy, error_multiplier, estimate;
    double                seconds = 0;

    /// The outcome of the nonlinear solve `solver`: its iterations, those
    /// of the linear solver (named in the line only if `linear_solver` is
    /// given) and the size of the contact set.
    void
    set_solve(const std::string  &solver,
              const NewtonReport &report,
              const std::string  &linear_solver,
              unsigned long long  contact_nodes);
  };

  /**
   * The progress line:
   *   "   <solver>: <n> iterations, <m> <linear solver>, <c> nodes in
   *    contact, energy error <e>, estimate <eta> (effectivity <eta/e>), <t> s"
   * with the parts that are known.
   */
  std::string
  to_string(const CycleNumbers &numbers);

  /// The columns cycle, cells, dofs, [dofs_condensed,] newton, linear,
  /// contact, [error_energy, error_lambda, eta, effectivity,] wall_s.
  void
  add_columns(dealii::ConvergenceTable &table, const CycleNumbers &numbers);

  /// The keys cycle, cells, newton_iterations, linear_iterations,
  /// contact_nodes, [error_energy, error_lambda_l2, eta, effectivity,]
  /// wall_seconds; the unknowns are the program's to count.
  Json
  to_json(const CycleNumbers &numbers);

} // namespace VI
