#pragma once

#include <deal.II/base/conditional_ostream.h>
#include <deal.II/base/convergence_table.h>
#include <deal.II/base/mpi.h>
#include <deal.II/base/timer.h>
#include <deal.II/base/types.h>

#include <vi/memory_budget.h>
#include <vi/run_record.h>
#include <vi/semismooth_newton.h>

#include <optional>
#include <string>

namespace dealii
{
  class ParameterHandler;
} // namespace dealii

namespace VI
{
  /**
   * What the stationary programs (step-membranes with Q_p or dG,
   * step-hho) share: the loop over a sequence of meshes, and what it
   * measures and records. A program derives from it and gives the steps of
   * the loop; run() takes them in the order of the algorithm:
   *
   *   check that the largest mesh fits in memory, make the first mesh,
   *   check the data on it (before anything is written);
   *   on every mesh: refine (after the first), set up and assemble the
   *   system, start from the last mesh's solution, solve, postprocess,
   *   measure the errors, write, record.
   *
   * The record (summary.json, the progress line, the convergence table and
   * the closing line) is the RunRecord's; a solver failure writes the
   * summary marked as failed before it propagates.
   */
  class StationaryProblem
  {
  public:
    void
    run();

    virtual ~StationaryProblem() = default;

  protected:
    /// `program` names the run in its header and summary.json; the
    /// program's `parameters` give the number of meshes (Mesh/Cycles) and
    /// the output directory.
    template <typename ProgramParameters>
    StationaryProblem(const std::string        &program,
                      const ProgramParameters  &parameters,
                      dealii::ParameterHandler &prm,
                      const MPI_Comm            comm)
        : StationaryProblem(program,
                            prm,
                            parameters.output.directory,
                            parameters.mesh.cycles,
                            MemoryBudget(parameters.mesh,
                                         parameters.discretization,
                                         parameters.linear_solver,
                                         comm),
                            comm)
    {
    }

    StationaryProblem(const std::string        &program,
                      dealii::ParameterHandler &prm,
                      const std::string        &output_directory,
                      const unsigned int        n_cycles,
                      const MemoryBudget       &memory_budget,
                      const MPI_Comm            comm);

    // The steps of run(), in the order it takes them.

    /// The line that says what this run solves, and how.
    virtual std::string
    description() const = 0;
    virtual void
    make_grid() = 0;
    /// The data must admit a solution; checked on the first mesh before
    /// anything is written (VI::check_membrane_data).
    virtual void
    check_data() const = 0;
    virtual void
    refine_mesh() = 0;
    virtual void
    setup_system() = 0;
    virtual void
    assemble_system() = 0;
    /// The first iterate on a mesh: the last mesh's solution carried over
    /// (nested iteration), or the initial guess.
    virtual void
    initialize_iterate() = 0;
    /// The mesh and the unknowns of a cycle, after its system is set up,
    /// from cycle_numbers(): the unknowns of the three nodal fields and
    /// `dofs` per field, or (HHO) `dofs` unknowns and `dofs_condensed` left
    /// after static condensation.
    virtual void
    print_cycle_header(const unsigned int cycle) const;
    virtual void
    solve() = 0;
    /// The solution's fields, its contact set and its estimate.
    virtual void
    postprocess() = 0;
    virtual void
    compute_errors() = 0;
    virtual void
    output_results(const unsigned int cycle) const = 0;
    /// What the cycle measured: its progress line, columns and record.
    virtual CycleNumbers
    cycle_numbers(const unsigned int cycle) const = 0;
    virtual void
    record_cycle(const unsigned int cycle) = 0;
    virtual void
    write_tables() const = 0;

    /// The numbers of a cycle on `cells` cells with `dofs` in the column
    /// "dofs", solved by `solver` (its linear solver named as in
    /// CycleNumbers::set_solve()): the members below and the cycle's time.
    CycleNumbers
    measured(const unsigned int       cycle,
             const unsigned long long cells,
             const unsigned long long dofs,
             const std::string       &solver,
             const std::string       &linear_solver) const;

    dealii::ParameterHandler   &prm;
    dealii::ConditionalOStream  pcout;
    mutable dealii::TimerOutput timer;

    // What each cycle measured.
    NewtonReport                    newton_report;
    dealii::types::global_dof_index n_contact_nodes = 0;
    /// Where the exact solution (and multiplier) is known.
    std::optional<double> error_energy, error_multiplier;

    dealii::ConvergenceTable table;
    /// Header, summary.json, failure guard, timing and closing line.
    RunRecord run_record;

  private:
    const unsigned int n_cycles;
    /// What the largest mesh needs, checked before the first is made.
    const MemoryBudget memory_budget;
  };
} // namespace VI
