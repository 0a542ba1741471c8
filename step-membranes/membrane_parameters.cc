// The .prm interface of step-membranes: the shared sections and the
// program's own entries (Benchmark, Nonlinear solver/Solver).

#include <vi/errors.h>
#include <vi/parameter_sections.h>

#include "membrane_problem.h"

namespace StepMembranes
{

  void
  Parameters::declare(ParameterHandler &prm)
  {
    VI::ProblemParameters::declare(prm,
                                   VI::membrane_test_case_names(),
                                   "seed-smooth");
    VI::MeshParameters::declare(prm);
    VI::DiscretizationParameters::declare(prm, "fem|sipg|nipg|iipg");
    VI::NonlinearSolverParameters::declare(prm, "exact|inexact|adaptive");
    VI::LinearSolverParameters::declare(prm, "direct|gmres", "direct");
    VI::EstimatorParameters::declare(prm);
    VI::OutputParameters::declare(prm);
    prm.enter_subsection("Nonlinear solver");
    prm.declare_entry(
      "Solver",
      "semismooth-newton",
      Patterns::Selection("semismooth-newton|petsc-vi"),
      "semismooth-newton: ours (C-function, Strategy). petsc-vi: the peer, "
      "PETSc's SNES VI on the same discrete problem (Method = fem; Strategy "
      "exact or inexact sets the KSP tolerance to Linear solver/Tolerance or "
      "the forcing term; Linear solver: direct = MUMPS, gmres with "
      "Preconditioner amg = BoomerAMG or ilu). PETSC_OPTIONS overrides.");
    prm.declare_entry("PETSc VI type",
                      "rsls",
                      Patterns::Selection("rsls|ssls"),
                      "SNESVINEWTONRSLS (reduced-space active set) or "
                      "SNESVINEWTONSSLS (semismooth Fischer-Burmeister with "
                      "line search).");
    prm.leave_subsection();
    prm.enter_subsection("Benchmark");
    prm.declare_entry("Reference Poisson solve",
                      "false",
                      Patterns::Bool(),
                      "After each cycle, solve -mu Lap u = f, u = g for each "
                      "membrane on the same mesh with CG + AMG and record its "
                      "wall time in summary.json (reference_poisson): the "
                      "cost unit of bench/membranes_cost.py.");
    prm.declare_entry("Compare with PETSc VI",
                      "false",
                      Patterns::Bool(),
                      "With Solver = semismooth-newton: solve every mesh a "
                      "second time with PETSc's SNES VI (PETSc VI type and "
                      "the Linear solver section, as for Solver = petsc-vi) "
                      "from the same initial iterate, and record its "
                      "iterations, wall time, error and distance to our "
                      "solution in summary.json (petsc_vi). The run goes on "
                      "with our solution.");
    prm.leave_subsection();
  }


  void
  Parameters::parse(ParameterHandler &prm)
  {
    VI::parse_shared_sections(*this, prm);
    prm.enter_subsection("Benchmark");
    reference_poisson_solve = prm.get_bool("Reference Poisson solve");
    compare_with_petsc_vi   = prm.get_bool("Compare with PETSc VI");
    prm.leave_subsection();
    prm.enter_subsection("Nonlinear solver");
    nonlinear_method = prm.get("Solver") == "petsc-vi" ?
                         NonlinearMethod::petsc_vi :
                         NonlinearMethod::semismooth_newton;
    petsc_vi_type    = prm.get("PETSc VI type");
    prm.leave_subsection();

    if (nonlinear_method == NonlinearMethod::petsc_vi)
      {
        if (nonlinear_solver.strategy == VI::Strategy::adaptive)
          throw VI::InputError(
            "Nonlinear solver/Strategy = adaptive stops our semismooth "
            "Newton by the estimators, which PETSc's SNES VI cannot do: use "
            "exact or inexact with Solver = petsc-vi");
        if (compare_with_petsc_vi)
          throw VI::InputError(
            "Benchmark/Compare with PETSc VI compares our semismooth Newton "
            "with PETSc's: set Nonlinear solver/Solver = semismooth-newton");
      }

    const VI::Strategy strategy = nonlinear_solver.strategy;
    if (strategy != VI::Strategy::exact &&
        linear_solver.solver != VI::LinearSolverType::gmres)
      throw VI::InputError(
        "Nonlinear solver/Strategy = " + VI::to_string(strategy) +
        " needs an iterative linear solver: set Linear "
        "solver/Solver = gmres");
    VI::require_estimators_where_read(&mesh, strategy, estimators.enabled);
    if (estimators.equilibrated_dual_norms() &&
        discretization.method != VI::Method::fem)
      throw VI::InputError("Estimators/Equilibrated dual norms is "
                           "implemented for Discretization/Method = fem: "
                           "leave it empty for the dG methods");
    if (estimators.sharpen_final && discretization.method != VI::Method::fem)
      throw VI::InputError("Estimators/Sharpen final estimate is implemented "
                           "for Discretization/Method = fem: set it to false "
                           "for the dG methods");
  }


  // Explicit instantiations of this file's members.
} // namespace StepMembranes
