#pragma once

#include <deal.II/base/parameter_handler.h>

namespace VI
{
  /**
   * Parse the sections that the membrane programs share (parameters.h):
   * Problem, Mesh, Discretization, Nonlinear solver, Linear solver,
   * Estimators and Output, into the members of the same names of a
   * program's parameters. The program reads its own entries after them.
   * `mesh_starts` as in NonlinearSolverParameters::declare().
   */
  template <class ProgramParameters>
  void
  parse_shared_sections(ProgramParameters        &parameters,
                        dealii::ParameterHandler &prm,
                        const bool                mesh_starts = true)
  {
    parameters.problem.parse(prm);
    parameters.mesh.parse(prm);
    parameters.discretization.parse(prm);
    parameters.nonlinear_solver.parse(prm, mesh_starts);
    parameters.linear_solver.parse(prm);
    parameters.estimators.parse(prm);
    parameters.output.parse(prm);
  }
} // namespace VI
