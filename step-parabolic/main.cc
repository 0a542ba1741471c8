// step-parabolic: the time-dependent contact between two membranes, backward
// Euler in time, semismooth Newton at every step, space-time a posteriori
// estimates that stop the solvers and can choose the time step. See
// doc/step-parabolic.md.

#include <vi/program.h>

#include "parabolic_problem.h"

int
main(int argc, char **argv)
{
  VI::ProgramDescription program;
  program.name    = "step-parabolic";
  program.purpose = "time-dependent contact between two membranes (backward "
                    "Euler, semismooth Newton, space-time estimators)";
  program.declare_parameters = StepParabolic::Parameters::declare;
  program.run = [](dealii::ParameterHandler &prm, const MPI_Comm comm) {
    StepParabolic::Parameters parameters;
    parameters.parse(prm);
    StepParabolic::ParabolicProblem<2> problem(parameters, prm, comm);
    problem.run();
  };
  return VI::run_program(argc, argv, program);
}
