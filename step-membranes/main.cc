// step-membranes: contact between two membranes, a variational inequality
// solved by semismooth Newton on a sequence of meshes, with conforming
// finite elements (Method = fem) or interior penalty discontinuous Galerkin
// methods (Method = sipg | nipg | iipg). See doc/step-membranes.md.

#include <vi/program.h>

#include "dg_membrane_problem.h"
#include "membrane_problem.h"

int
main(int argc, char **argv)
{
  VI::ProgramDescription program;
  program.name    = "step-membranes";
  program.purpose = "contact between two membranes (finite elements of any "
                    "degree or interior penalty dG, semismooth Newton)";
  program.declare_parameters = [](dealii::ParameterHandler &prm) {
    StepMembranes::Parameters::declare(prm);
    StepMembranes::DGParameters::declare(prm);
  };
  program.run = [](dealii::ParameterHandler &prm, const MPI_Comm comm) {
    StepMembranes::Parameters parameters;
    parameters.parse(prm);
    StepMembranes::DGParameters dg_parameters;
    dg_parameters.parse(prm);
    if (parameters.discretization.method == VI::Method::fem)
      {
        StepMembranes::MembraneProblem<2> problem(parameters, prm, comm);
        problem.run();
      }
    else
      {
        StepMembranes::DGMembraneProblem<2> problem(parameters,
                                                    dg_parameters,
                                                    prm,
                                                    comm);
        problem.run();
      }
  };
  return VI::run_program(argc, argv, program);
}
