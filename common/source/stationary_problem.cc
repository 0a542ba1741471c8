#include <deal.II/base/utilities.h>

#include <vi/nodal_fields.h>
#include <vi/stationary_problem.h>

#include <iostream>

namespace VI
{
  using namespace dealii;


  StationaryProblem::StationaryProblem(const std::string  &program,
                                       ParameterHandler   &prm,
                                       const std::string  &output_directory,
                                       const unsigned int  n_cycles,
                                       const MemoryBudget &memory_budget,
                                       const MPI_Comm      comm)
      : prm(prm)
      , pcout(std::cout, Utilities::MPI::this_mpi_process(comm) == 0)
      // Wall times of rank 0: a TimerOutput without communicator needs no MPI
      // in its destructor, which also runs when a failure unwinds the stack.
      , timer(pcout, TimerOutput::never, TimerOutput::wall_times)
      , run_record(program, output_directory, timer, comm)
      , n_cycles(n_cycles)
      , memory_budget(memory_budget)
  {
  }


  void
  StationaryProblem::run()
  {
    // A run that cannot fit, or data that admit no solution, end the run
    // before anything is allocated or written.
    memory_budget.check();
    make_grid();
    check_data();
    run_record.start(prm, description());

    for (unsigned int cycle = 0; cycle < n_cycles; ++cycle)
      {
        run_record.start_cycle();
        if (cycle > 0)
          refine_mesh();
        setup_system();
        assemble_system();
        initialize_iterate();
        print_cycle_header(cycle);

        run_record.guard([&] { solve(); });
        postprocess();
        compute_errors();
        output_results(cycle);
        run_record.stop_cycle();

        pcout << to_string(cycle_numbers(cycle)) << std::endl;
        record_cycle(cycle);
      }

    write_tables();
    run_record.finish(
      "solution_*.pvtu (ParaView), convergence.txt, summary.json");
  }


  CycleNumbers
  StationaryProblem::measured(const unsigned int       cycle,
                              const unsigned long long cells,
                              const unsigned long long dofs,
                              const std::string       &solver,
                              const std::string       &linear_solver) const
  {
    CycleNumbers numbers(cycle, cells, dofs, run_record.cycle_seconds());
    numbers.set_solve(solver, newton_report, linear_solver, n_contact_nodes);
    numbers.error_energy     = error_energy;
    numbers.error_multiplier = error_multiplier;
    return numbers;
  }


  void
  StationaryProblem::print_cycle_header(const unsigned int cycle) const
  {
    const CycleNumbers numbers = cycle_numbers(cycle);
    pcout << "Cycle " << cycle << ": " << numbers.cells << " cells, ";
    if (numbers.dofs_condensed)
      pcout << numbers.dofs << " unknowns, " << *numbers.dofs_condensed
            << " after condensation" << std::endl;
    else
      pcout << NodalFields::n_fields * numbers.dofs << " unknowns ("
            << numbers.dofs << " per field)" << std::endl;
  }
} // namespace VI
