#pragma once

#include <deal.II/base/mpi.h>
#include <deal.II/base/parameter_handler.h>

#include <functional>
#include <string>

namespace VI
{
  /**
   * What a program tells run_program(): its name, one line on what it
   * solves, how to declare its parameters, and how to run once they are
   * read.
   */
  struct ProgramDescription
  {
    std::string                                     name;
    std::string                                     purpose;
    std::function<void(dealii::ParameterHandler &)> declare_parameters;
    std::function<void(dealii::ParameterHandler &, const MPI_Comm)> run;
  };

  /**
   * The main() of every program in the suite:
   *
   *   program [--help | --print-parameters | file.prm]
   *
   * It initialises MPI (and through it PETSc, p4est and Trilinos), reads the
   * parameter file, runs, and maps every failure to one line on stderr
   * (printed by rank 0) and an exit status:
   *   0 success; 1 bad input (parameter file, data, output directory);
   *   2 a solver failed (the message says which and why); 3 internal error.
   */
  int
  run_program(int argc, char **argv, const ProgramDescription &program);

  /**
   * run_program() for the usual program: one Parameters class with static
   * declare() and parse(), and a Problem(parameters, prm, comm) with run().
   * `check`, if given, runs before the parameters are read (e.g. to refuse
   * a number of ranks the program does not support).
   */
  template <typename Parameters, typename Problem>
  int
  run_program(int                                  argc,
              char                               **argv,
              const std::string                   &name,
              const std::string                   &purpose,
              const std::function<void(MPI_Comm)> &check = {})
  {
    ProgramDescription program;
    program.name               = name;
    program.purpose            = purpose;
    program.declare_parameters = Parameters::declare;
    program.run = [&check](dealii::ParameterHandler &prm, const MPI_Comm comm) {
      if (check)
        check(comm);
      Parameters parameters;
      parameters.parse(prm);
      Problem problem(parameters, prm, comm);
      problem.run();
    };
    return run_program(argc, argv, program);
  }

  /**
   * Create `directory` (on rank 0) and check that a file can be written
   * into it; throws InputError on every rank otherwise.
   */
  void
  prepare_output_directory(const std::string &directory, const MPI_Comm comm);

  /**
   * Make an abort in p4est's support library (libsc: a failed allocation,
   * or a failed check) end the run like a std::bad_alloc in run_program():
   * one line with the reason, exit status 1 for a failed allocation (3
   * otherwise), MPI_Abort on runs of several ranks. run_program() calls it
   * after MPI_Init.
   */
  void
  report_libsc_aborts_in_one_line(const MPI_Comm comm);

  /// The header every run prints: program, version, deal.II, ranks, threads.
  std::string
  run_header(const std::string &program, const MPI_Comm comm);
} // namespace VI
