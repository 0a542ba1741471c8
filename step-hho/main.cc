// step-hho: contact between two membranes with the Hybrid High-Order
// method and static condensation, solved by semismooth Newton on a sequence
// of meshes. See doc/step-hho.md.

#include <vi/program.h>

#include "hho_problem.h"

int
main(int argc, char **argv)
{
  VI::ProgramDescription program;
  program.name    = "step-hho";
  program.purpose = "contact between two membranes (Hybrid High-Order "
                    "method with static condensation, semismooth Newton)";
  program.declare_parameters = StepHHO::Parameters::declare;
  program.run = [](dealii::ParameterHandler &prm, const MPI_Comm comm) {
    StepHHO::Parameters parameters;
    parameters.parse(prm);
    StepHHO::HHOProblem<2> problem(parameters, prm, comm);
    problem.run();
  };
  return VI::run_program(argc, argv, program);
}
