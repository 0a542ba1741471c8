// step-parabolic: the time-dependent contact between two membranes, backward
// Euler in time, semismooth Newton at every step, space-time a posteriori
// estimates that stop the solvers and can choose the time step. See
// doc/step-parabolic.md.

#include <vi/program.h>

#include "parabolic_problem.h"

int
main(int argc, char **argv)
{
  return VI::run_program<StepParabolic::Parameters,
                         StepParabolic::ParabolicProblem<2>>(
    argc,
    argv,
    "step-parabolic",
    "time-dependent contact between two membranes (backward Euler, "
    "semismooth Newton, space-time estimators)");
}
