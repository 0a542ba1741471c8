// step-twophase: water-hydrogen flow in 1D with gas appearance and
// disappearance, a system of evolution equations with nonlinear
// complementarity constraints solved by semismooth Newton with a posteriori
// error control. See doc/step-twophase.md.

#include "twophase_problem.h"

#include <vi/program.h>

int
main(int argc, char **argv)
{
  VI::ProgramDescription program;
  program.name               = "step-twophase";
  program.purpose            = "1D finite volume water-hydrogen flow with gas "
                               "appearance and disappearance (Couplex-Gas benchmark)";
  program.declare_parameters = StepTwoPhase::Parameters::declare;
  program.run = [](dealii::ParameterHandler &prm, const MPI_Comm comm) {
    StepTwoPhase::Parameters parameters;
    parameters.parse(prm);
    StepTwoPhase::TwoPhaseProblem problem(parameters, prm, comm);
    problem.run();
  };
  return VI::run_program(argc, argv, program);
}
