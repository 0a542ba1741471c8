// step-membranes: contact between two membranes, a variational inequality
// solved by semismooth Newton on a sequence of meshes. See
// doc/step-membranes.md.

#include <vi/program.h>

#include "membrane_problem.h"

int
main(int argc, char **argv)
{
  VI::ProgramDescription program;
  program.name    = "step-membranes";
  program.purpose = "contact between two membranes (finite elements of any "
                    "degree, semismooth Newton)";
  program.declare_parameters = StepMembranes::Parameters::declare;
  program.run = [](dealii::ParameterHandler &prm, const MPI_Comm comm) {
    StepMembranes::Parameters parameters;
    parameters.parse(prm);
    StepMembranes::MembraneProblem<2> problem(parameters, prm, comm);
    problem.run();
  };
  return VI::run_program(argc, argv, program);
}
