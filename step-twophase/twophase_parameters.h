#pragma once

#include <deal.II/base/parameter_handler.h>

#include <vi/parameters.h>

#include "twophase_model.h"

#include <string>
#include <vector>

namespace StepTwoPhase
{
  /// Boundary conditions of the benchmark (SI units; times in seconds).
  struct BoundaryParameters
  {
    double injection_rate       = 5.57e-6 / seconds_per_year; // kg m^-2 s^-1
    double injection_duration   = 5e5 * seconds_per_year;     // s
    double right_pressure       = 1e6;                        // Pa
    double right_saturation     = 1.;
    double right_molar_fraction = 0.;
  };


  struct MeshParameters
  {
    double       length  = 200.; // m
    unsigned int n_cells = 1000;
  };


  /// Time stepping (entered in years, stored in seconds).
  struct TimeSteppingParameters
  {
    double              final_time           = 1e6 * seconds_per_year;
    double              time_step            = 5e3 * seconds_per_year;
    double              minimal_time_step    = 1. * seconds_per_year;
    double              reduction_factor     = 0.5;
    double              growth_factor        = 2.;
    double              saturation_tolerance = 1e-6;
    std::vector<double> output_times; ///< sorted, in [0, final_time]
    unsigned int        checkpoint_interval = 20;
    bool                resume              = false;
  };


  /**
   * The .prm interface of step-twophase: the physics and the boundary data
   * of the Couplex-Gas / MoMaS benchmark (its values are the defaults), the
   * mesh, the time stepping, and the shared sections "Nonlinear solver",
   * "Linear solver" and "Output" with the entries this program adds to
   * them.
   */
  struct Parameters
  {
    PhysicalParameters     physics;
    BoundaryParameters     boundary;
    MeshParameters         mesh;
    TimeSteppingParameters time;

    VI::NonlinearSolverParameters nonlinear_solver;
    std::string                nonlinear_solver_package = "semismooth-newton";
    VI::LinearSolverParameters linear_solver;
    std::string                ordering = "field-wise";
    VI::OutputParameters       output;
    unsigned int               progress_interval = 1;

    static void
    declare(dealii::ParameterHandler &prm);
    void
    parse(dealii::ParameterHandler &prm);
  };
} // namespace StepTwoPhase
