#include "parabolic_parameters.h"

#include <vi/errors.h>
#include <vi/parameter_sections.h>

#include <sstream>

namespace StepParabolic
{
  using dealii::ParameterHandler;
  // The patterns of the declarations: Double(), Selection("a|b"), ...
  using namespace dealii::Patterns;

  void
  Parameters::declare(ParameterHandler &prm)
  {
    VI::ProblemParameters::declare(prm, "ring|expression", "ring", "x, y, t");
    prm.enter_subsection("Problem");
    prm.enter_subsection("Expression");
    {
      prm.declare_entry("u1_0",
                        "0",
                        Anything(),
                        "Initial value of u1 (variables x, y). With an exact "
                        "solution, give u1 at t = 0.");
      prm.declare_entry("u2_0",
                        "0",
                        Anything(),
                        "Initial value of u2 (variables x, y); u1_0 >= u2_0 "
                        "is required everywhere.");
    }
    prm.leave_subsection();
    prm.leave_subsection();

    VI::DomainParameters::declare(prm,
                                  "disk",
                                  "5",
                                  "Global refinements of the coarse mesh; "
                                  "the mesh is the same at all time steps.");

    VI::DiscretizationParameters::declare(prm, "fem");
    // (without "Nested iteration" and "Initial guess": Newton starts every
    // step from the previous step's solution)
    VI::NonlinearSolverParameters::declare(prm,
                                           "exact|inexact|adaptive",
                                           /*mesh_starts=*/false);
    VI::LinearSolverParameters::declare(prm, "direct|gmres", "gmres");
    VI::EstimatorParameters::declare(prm);
    // Long runs: only the accepted iterates are estimated unless asked.
    prm.enter_subsection("Estimators");
    prm.set("At every check", "false");
    prm.leave_subsection();
    VI::OutputParameters::declare(prm);
    prm.enter_subsection("Output");
    prm.declare_entry("Compare with",
                      "",
                      Anything(),
                      "The output directory of another run of the same "
                      "problem (same final time, same number of ranks), e.g. "
                      "with another solver strategy: at the end, the norms "
                      "of the difference between the two final solutions "
                      "(from its checkpoint) are reported. Empty: none.");
    prm.leave_subsection();

    prm.enter_subsection("Time stepping");
    {
      prm.declare_entry("Final time", "0.3", Double(), "T (> 0).");
      prm.declare_entry("Time step",
                        "1e-3",
                        Double(),
                        "dt (> 0): the fixed time step, or the first one "
                        "with Adaptive = true. The last step is shortened to "
                        "end at the final time.");
      prm.declare_entry("Adaptive",
                        "false",
                        Bool(),
                        "Choose dt_n by the time-error estimator: keep the "
                        "temporal estimator eta_time^n + eta_osc^n close to "
                        "'Time-space ratio' times the spatial one "
                        "eta_space^n (doc/step-parabolic.md); false keeps dt "
                        "fixed.");
      prm.declare_entry("Time-space ratio",
                        "1",
                        Double(),
                        "Adaptive: the target of (eta_time^n + eta_osc^n) / "
                        "eta_space^n (> 0).");
      prm.declare_entry("Minimal time step",
                        "1e-6",
                        Double(),
                        "Adaptive: dt is not reduced below this (> 0).");
      prm.declare_entry("Maximal time step",
                        "0.1",
                        Double(),
                        "Adaptive: dt is not increased beyond this "
                        "(>= Minimal time step).");
      prm.declare_entry("Growth factor",
                        "2",
                        Double(),
                        "Adaptive: dt grows by at most this factor (> 1) "
                        "from one step to the next.");
      prm.declare_entry(
        "Rejection factor",
        "2",
        Double(),
        "Adaptive: a step whose ratio of the temporal to "
        "the spatial estimator exceeds this factor (> 1) times the target is "
        "recomputed with a shorter dt.");
      prm.declare_entry("Output interval",
                        "10",
                        Integer(0),
                        "Write the solution (VTU, listed in solution.pvd) "
                        "every this many steps, and at t = 0 and the final "
                        "time; 0: only at t = 0 and the final time.");
      prm.declare_entry("Checkpoint interval",
                        "0",
                        Integer(0),
                        "Write a checkpoint (mesh and solution, "
                        "Output/Directory/checkpoint.*) every this many "
                        "steps, and at the end of the run; 0: only at the "
                        "end.");
      prm.declare_entry("Steps per run",
                        "0",
                        Integer(0),
                        "End the run after this many steps (with a "
                        "checkpoint), e.g. for a wall-time limit; continue "
                        "it with Resume = true. 0: no limit.");
      prm.declare_entry("Resume",
                        "false",
                        Bool(),
                        "Continue from the checkpoint in Output/Directory, "
                        "written by a run of the same problem (Problem, "
                        "Mesh, Discretization); solver, time stepping and "
                        "output settings may differ.");
    }
    prm.leave_subsection();
  }


  namespace
  {
    void
    require(const bool condition, const std::string &message)
    {
      if (!condition)
        throw VI::InputError(message);
    }

    std::string
    text(const double value)
    {
      std::ostringstream out;
      out << value;
      return out.str();
    }
  } // namespace


  void
  Parameters::parse(ParameterHandler &prm)
  {
    VI::parse_shared_sections(*this, prm, /*mesh_starts=*/false);
    prm.enter_subsection("Problem");
    prm.enter_subsection("Expression");
    problem.u1_0 = prm.get("u1_0");
    problem.u2_0 = prm.get("u2_0");
    prm.leave_subsection();
    prm.leave_subsection();
    prm.enter_subsection("Output");
    compare_with = prm.get("Compare with");
    prm.leave_subsection();

    prm.enter_subsection("Time stepping");
    for (const auto &[name, value] :
         {std::pair<const char *, double *>{"Final time", &time.final_time},
          {"Time step", &time.time_step},
          {"Time-space ratio", &time.time_space_ratio},
          {"Minimal time step", &time.minimal_time_step},
          {"Maximal time step", &time.maximal_time_step},
          {"Growth factor", &time.growth_factor},
          {"Rejection factor", &time.rejection_factor}})
      *value = prm.get_double(name);
    for (const auto &[name, value] :
         {std::pair<const char *, unsigned int *>{"Output interval",
                                                  &time.output_interval},
          {"Checkpoint interval", &time.checkpoint_interval},
          {"Steps per run", &time.steps_per_run}})
      *value = prm.get_integer(name);
    time.adaptive = prm.get_bool("Adaptive");
    time.resume   = prm.get_bool("Resume");
    prm.leave_subsection();

    const auto &t = time;
    // "Time stepping/<name> = <value> must be <what>" unless value > bound.
    const auto require_above = [](const std::string &name,
                                  const double       value,
                                  const double       bound,
                                  const std::string &what) {
      require(value > bound,
              "Time stepping/" + name + " = " + text(value) + " must be " +
                what);
    };
    require_above("Final time", t.final_time, 0, "positive");
    require_above("Time step", t.time_step, 0, "positive");
    if (t.adaptive)
      {
        require_above("Time-space ratio", t.time_space_ratio, 0, "positive");
        require_above("Minimal time step", t.minimal_time_step, 0, "positive");
        require(t.maximal_time_step >= t.minimal_time_step,
                "Time stepping/Maximal time step = " +
                  text(t.maximal_time_step) +
                  " must not be below Minimal time step = " +
                  text(t.minimal_time_step));
        require(t.time_step >= t.minimal_time_step &&
                  t.time_step <= t.maximal_time_step,
                "Time stepping/Time step = " + text(t.time_step) +
                  " must lie in [Minimal time step, Maximal time step] = [" +
                  text(t.minimal_time_step) + ", " + text(t.maximal_time_step) +
                  "] with Adaptive = true");
        require_above("Growth factor", t.growth_factor, 1, "greater than 1");
        require_above("Rejection factor",
                      t.rejection_factor,
                      1,
                      "greater than 1");
        require(estimators.enabled,
                "Time stepping/Adaptive = true chooses dt with the "
                "estimators: set Estimators/Enabled = true");
      }

    require(!problem.smooth_obstacle,
            "Problem/Smooth obstacle serves the stationary estimate of "
            "step-membranes; step-parabolic does not use it: remove it");
    const VI::Strategy strategy = nonlinear_solver.strategy;
    require(strategy == VI::Strategy::exact ||
              linear_solver.solver == VI::LinearSolverType::gmres,
            "Nonlinear solver/Strategy = " + VI::to_string(strategy) +
              " needs an iterative linear solver: set Linear solver/Solver "
              "= gmres");
    VI::require_estimators_where_read(nullptr, strategy, estimators.enabled);
    require(!estimators.equilibrated_dual_norms(),
            "Estimators/Equilibrated dual norms is implemented for "
            "step-membranes (fem): leave it empty for step-parabolic");
    require(!estimators.sharpen_final,
            "Estimators/Sharpen final estimate is implemented for "
            "step-membranes (fem): set it to false for step-parabolic");
    require(linear_solver.solver != VI::LinearSolverType::gmres ||
              linear_solver.preconditioner != VI::PreconditionerType::amg ||
              problem.mu1 == problem.mu2,
            "Linear solver/Preconditioner = amg needs mu1 = mu2 in "
            "step-parabolic (the mass term couples the mean and the gap "
            "otherwise); use ilu");
  }
} // namespace StepParabolic
