// step-hho: contact between two membranes with the Hybrid High-Order
// method and static condensation, solved by semismooth Newton on a sequence
// of meshes. See doc/step-hho.md.

#include <vi/program.h>

#include "hho_problem.h"

int
main(int argc, char **argv)
{
  return VI::run_program<StepHHO::Parameters, StepHHO::HHOProblem<2>>(
    argc,
    argv,
    "step-hho",
    "contact between two membranes (Hybrid High-Order method with static "
    "condensation, semismooth Newton)");
}
