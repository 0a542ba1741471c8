#pragma once

#include <deal.II/base/parameter_handler.h>

#include <vi/parameters.h>

#include <string>

namespace StepParabolic
{
  /// Problem: the shared section, plus the initial data u^0 = (u1_0, u2_0).
  struct ProblemParameters : VI::ProblemParameters
  {
    std::string u1_0, u2_0; ///< formulas in x, y (Problem/Expression)
  };


  struct TimeSteppingParameters
  {
    double       final_time          = 0.3;
    double       time_step           = 1e-3;
    bool         adaptive            = false;
    double       time_space_ratio    = 1.;
    double       minimal_time_step   = 1e-6;
    double       maximal_time_step   = 0.1;
    double       growth_factor       = 2.;
    double       rejection_factor    = 2.;
    unsigned int output_interval     = 10;
    unsigned int checkpoint_interval = 0;
    unsigned int steps_per_run       = 0;
    bool         resume              = false;
  };


  /**
   * The .prm interface of step-parabolic: the shared sections that
   * apply (Problem, Mesh, Discretization, Nonlinear solver, Linear solver,
   * Estimators, Output) and "Time stepping".
   */
  struct Parameters
  {
    ProblemParameters             problem;
    VI::DomainParameters          mesh;
    VI::DiscretizationParameters  discretization;
    VI::NonlinearSolverParameters nonlinear_solver;
    VI::LinearSolverParameters    linear_solver;
    VI::EstimatorParameters       estimators;
    VI::OutputParameters          output;
    /// Output/Compare with: the directory of another run of the problem.
    std::string            compare_with;
    TimeSteppingParameters time;

    static void
    declare(dealii::ParameterHandler &prm);
    void
    parse(dealii::ParameterHandler &prm);
  };
} // namespace StepParabolic
