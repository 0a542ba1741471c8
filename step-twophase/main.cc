// step-twophase: water-hydrogen flow in 1D with gas appearance and
// disappearance, a system of evolution equations with nonlinear
// complementarity constraints solved by semismooth Newton with a posteriori
// error control. See doc/step-twophase.md.

#include <deal.II/base/mpi.h>
#include <deal.II/base/multithread_info.h>

#include <vi/errors.h>
#include <vi/program.h>

#include "twophase_problem.h"

#include <string>

int
main(int argc, char **argv)
{
  const auto serial = [](const MPI_Comm comm) {
    // 1D: p4est has no 1D meshes, and 1000 cells take a second.
    const unsigned int ranks = dealii::Utilities::MPI::n_mpi_processes(comm);
    if (ranks > 1)
      throw VI::InputError("step-twophase is serial (a 1D finite volume "
                           "problem): run it on one MPI rank, not " +
                           std::to_string(ranks));
    // One thread: with a few thousand unknowns, TBB's threads cost more
    // than they bring.
    dealii::MultithreadInfo::set_thread_limit(1);
  };
  return VI::run_program<StepTwoPhase::Parameters,
                         StepTwoPhase::TwoPhaseProblem>(
    argc,
    argv,
    "step-twophase",
    "1D finite volume water-hydrogen flow with gas appearance and "
    "disappearance (Couplex-Gas benchmark)",
    serial);
}
