#include "twophase_parameters.h"

#include <deal.II/base/utilities.h>

#include <vi/errors.h>

#include <algorithm>
#include <sstream>

namespace StepTwoPhase
{
  using dealii::ParameterHandler;
  // The patterns of the declarations: Double(), Selection("a|b"), ...
  using namespace dealii::Patterns;

  namespace
  {
    /// Throw InputError "Section/Name = value must be <condition>" unless ok.
    void
    require(const bool         ok,
            const std::string &name,
            const double       value,
            const std::string &condition)
    {
      if (!ok)
        {
          std::ostringstream message;
          message << name << " = " << value << " must be " << condition;
          throw VI::InputError(message.str());
        }
    }


    /// A value that must be > 0, or >= 0 where zero is allowed.
    struct LowerBound
    {
      const char *name;
      double      value;
      bool        zero_allowed = false;
    };

    /// require() each bound in turn, naming the entry "section/name".
    void
    require_bounds(const std::string                      &section,
                   const std::initializer_list<LowerBound> bounds)
    {
      for (const LowerBound &b : bounds)
        require(b.zero_allowed ? b.value >= 0 : b.value > 0,
                section + b.name,
                b.value,
                b.zero_allowed ? ">= 0" : "> 0");
    }


    // The entries of Physics (all numbers): one table declares and parses
    // them.
    struct PhysicsEntry
    {
      const char *name;
      double PhysicalParameters::*field;
      const char                 *default_value;
      const char                 *documentation;
    };

    const PhysicsEntry physics_entries[] = {
      {"Porosity", &PhysicalParameters::porosity, "0.15", "phi, in (0, 1]."},
      {"Permeability",
       &PhysicalParameters::permeability,
       "5e-20",
       "Intrinsic permeability K, m^2 (> 0)."},
      {"van Genuchten pressure",
       &PhysicalParameters::van_genuchten_pressure,
       "2e6",
       "P_r of P_cp = P_r (S_e^(-1/m) - 1)^(1/n), Pa (> 0)."},
      {"van Genuchten n",
       &PhysicalParameters::van_genuchten_n,
       "1.49",
       "n > 1 of van Genuchten-Mualem; m = 1 - 1/n."},
      {"Residual liquid saturation",
       &PhysicalParameters::residual_liquid_saturation,
       "0.4",
       "S_lr in the effective saturation S_e = (S - S_lr) / "
       "(1 - S_lr - S_gr); S_lr, S_gr >= 0, S_lr + S_gr < 1."},
      {"Residual gas saturation",
       &PhysicalParameters::residual_gas_saturation,
       "0",
       "S_gr."},
      {"Liquid viscosity",
       &PhysicalParameters::liquid_viscosity,
       "1e-3",
       "mu_l, Pa s (> 0)."},
      {"Gas viscosity",
       &PhysicalParameters::gas_viscosity,
       "9e-6",
       "mu_g, Pa s (> 0)."},
      {"Water density",
       &PhysicalParameters::water_density,
       "1000",
       "rho_w, kg/m^3 (> 0); the liquid is incompressible."},
      {"Water molar mass",
       &PhysicalParameters::water_molar_mass,
       "1e-2",
       "M_w, kg/mol (> 0; the benchmark's value, not water's "
       "0.018). The liquid has beta^l = rho_w / M_w moles "
       "per m^3."},
      {"Hydrogen molar mass",
       &PhysicalParameters::hydrogen_molar_mass,
       "2e-3",
       "M_h, kg/mol (> 0)."},
      {"Henry constant",
       &PhysicalParameters::henry_constant,
       "7.65e-6",
       "H, mol/(Pa m^3) (> 0): at equilibrium with gas, the "
       "liquid holds H P^g moles of hydrogen per m^3."},
      {"Diffusion coefficient",
       &PhysicalParameters::diffusion_coefficient,
       "3e-9",
       "D of dissolved hydrogen (Fick), m^2/s (>= 0)."},
      {"Temperature", &PhysicalParameters::temperature, "303", "T, K (> 0)."},
      {"Gas constant",
       &PhysicalParameters::gas_constant,
       "8.314",
       "R, J/(mol K) (> 0); ideal gas P^g = rho^g R T / M_h."},
      {"Regularization",
       &PhysicalParameters::regularization,
       "1e-5",
       "Width eps in S_e, in (0, 0.1], of the intervals "
       "[1 - eps, 1] and [0, eps] where the van "
       "Genuchten-Mualem laws (infinite slopes at S_e = 1) "
       "are replaced by linear pieces."}};


    void
    declare_physics(ParameterHandler &prm)
    {
      prm.enter_subsection("Physics");
      for (const PhysicsEntry &entry : physics_entries)
        prm.declare_entry(entry.name,
                          entry.default_value,
                          Double(),
                          entry.documentation);
      prm.leave_subsection();
    }


    void
    declare_boundary_conditions(ParameterHandler &prm)
    {
      prm.enter_subsection("Boundary conditions");
      {
        prm.declare_entry(
          "Injection rate",
          "5.57e-6",
          Double(),
          "Hydrogen injected at x = 0, kg/(m^2 year) (>= 0); no "
          "water flows through x = 0.");
        prm.declare_entry("Injection duration",
                          "5e5",
                          Double(),
                          "Years of injection (>= 0); no flux at x = 0 after.");
        prm.declare_entry(
          "Right pressure",
          "1e6",
          Double(),
          "Liquid pressure at x = L, Pa (> 0); also the initial "
          "pressure and the pressure scale P_ref.");
        prm.declare_entry("Right saturation",
                          "1",
                          Double(),
                          "Liquid saturation at x = L and initially, in "
                          "(S_lr, 1].");
        prm.declare_entry("Right molar fraction",
                          "0",
                          Double(),
                          "Dissolved hydrogen at x = L and initially (>= 0); "
                          "the right state must satisfy the phase equilibrium "
                          "constraint.");
      }
      prm.leave_subsection();
    }


    void
    declare_mesh(ParameterHandler &prm)
    {
      prm.enter_subsection("Mesh");
      {
        prm.declare_entry("Length",
                          "200",
                          Double(),
                          "L, m (> 0): Omega = (0, L).");
        prm.declare_entry("Number of cells",
                          "1000",
                          Integer(1, 1000000000),
                          "Uniform cells of the finite volume mesh.");
      }
      prm.leave_subsection();
    }


    void
    declare_time_stepping(ParameterHandler &prm)
    {
      prm.enter_subsection("Time stepping");
      {
        prm.declare_entry("Final time", "1e6", Double(), "Years (> 0).");
        prm.declare_entry("Time step",
                          "5000",
                          Double(),
                          "Nominal time step, years (> 0). Steps are shortened "
                          "to land on the output times, the end of the "
                          "injection and the final time.");
        prm.declare_entry("Minimal time step",
                          "1",
                          Double(),
                          "Years, in (0, Time step]: a step that fails with a "
                          "shorter one ends the run (exit status 2).");
        prm.declare_entry("Reduction factor",
                          "0.5",
                          Double(),
                          "A failed step (no convergence, NaN, saturation "
                          "outside [0, 1]) is retried with dt times this "
                          "factor, in (0, 1).");
        prm.declare_entry("Growth factor",
                          "2",
                          Double(),
                          "After a reduction, each successful step multiplies "
                          "dt by this factor (>= 1) until the nominal step is "
                          "reached again.");
        prm.declare_entry("Saturation tolerance",
                          "1e-6",
                          Double(),
                          "A step whose saturation leaves [0, 1] by more than "
                          "this (>= 0) counts as failed; the adaptive strategy "
                          "does not stop Newton at such an iterate.");
        prm.declare_entry("Output times",
                          "2500, 12500, 42500, 105000, 350000, 500000, 1000000",
                          List(Double()),
                          "Years, in [0, Final time]: VTU and profile CSV "
                          "written at these times (the defaults are the times "
                          "of the published figures, the end of the injection "
                          "and the final time).");
        prm.declare_entry("Checkpoint interval",
                          "20",
                          Integer(0),
                          "Write the state every this many steps (and at the "
                          "end) to Output/Directory/checkpoint.txt; 0: only at "
                          "the end.");
        prm.declare_entry("Resume",
                          "false",
                          Bool(),
                          "Continue from Output/Directory/checkpoint.txt "
                          "(written by a run with the same parameters, except "
                          "the final time, output and checkpoint settings).");
      }
      prm.leave_subsection();
    }


    void
    declare_nonlinear_solver(ParameterHandler &prm)
    {
      VI::NonlinearSolverParameters::declare(prm,
                                             "exact|inexact|adaptive",
                                             /*mesh_starts=*/false);
      prm.enter_subsection("Nonlinear solver");
      prm.set("Tolerance", "1e-8");
      prm.declare_entry("Watchdog steps",
                        "8",
                        Integer(0),
                        "Fischer-Burmeister's line search: up to this many "
                        "full Newton steps are taken without the Armijo "
                        "test against the last iterate that passed it; if "
                        "the merit function has not fallen below that "
                        "iterate's by then, Newton returns to it and "
                        "backtracks. 0: every step is tested (Armijo "
                        "backtracking alone, which cuts most steps of a "
                        "time step, doc/step-twophase.md).");
      prm.declare_entry("Solver",
                        "semismooth-newton",
                        Selection("semismooth-newton|kinsol"),
                        "semismooth-newton: the suite's semismooth Newton "
                        "(min or FB, the strategies above); kinsol: SUNDIALS "
                        "KINSOL, Newton with line search on the "
                        "Fischer-Burmeister form (exact or inexact strategy; "
                        "inexact takes KINSOL's forcing terms).");
      prm.leave_subsection();
    }


    void
    declare_linear_solver(ParameterHandler &prm)
    {
      VI::LinearSolverParameters::declare(prm, "gmres|direct", "gmres");
      prm.enter_subsection("Linear solver");
      prm.set("Tolerance", "1e-10");
      prm.set("Check interval", "1");
      prm.set("Krylov dimension", "50");
      prm.declare_entry(
        "Ordering",
        "cell-wise",
        Selection("cell-wise|field-wise"),
        "Numbering of the unknowns. cell-wise: (S, P, chi) cell "
        "after cell, a block tridiagonal matrix whose ILU(0) is "
        "its exact LU factorisation (GMRES converges in one "
        "iteration); field-wise: all S, all P, all chi, where "
        "ILU(0) drops the fill between the fields and GMRES "
        "iterates (the setting of the strategy comparisons).");
      prm.leave_subsection();
    }


    void
    declare_output(ParameterHandler &prm)
    {
      VI::OutputParameters::declare(prm);
      prm.enter_subsection("Output");
      prm.declare_entry("Progress interval",
                        "1",
                        Integer(1),
                        "Print a progress line every this many time steps.");
      prm.leave_subsection();
    }


    /// The ranges of the physical parameters.
    void
    check_physics(const PhysicalParameters &p)
    {
      const std::string s = "Physics/";
      require(p.porosity > 0 && p.porosity <= 1,
              s + "Porosity",
              p.porosity,
              "in (0, 1]");
      require_bounds(s,
                     {{"Permeability", p.permeability},
                      {"van Genuchten pressure", p.van_genuchten_pressure}});
      require(p.van_genuchten_n > 1,
              s + "van Genuchten n",
              p.van_genuchten_n,
              "> 1 (m = 1 - 1/n must be positive)");
      require_bounds(
        s,
        {{"Residual liquid saturation", p.residual_liquid_saturation, true},
         {"Residual gas saturation", p.residual_gas_saturation, true}});
      require(p.residual_liquid_saturation + p.residual_gas_saturation < 1,
              s + "Residual liquid saturation + Residual gas saturation",
              p.residual_liquid_saturation + p.residual_gas_saturation,
              "< 1");
      require_bounds(s,
                     {{"Liquid viscosity", p.liquid_viscosity},
                      {"Gas viscosity", p.gas_viscosity},
                      {"Water density", p.water_density},
                      {"Water molar mass", p.water_molar_mass},
                      {"Hydrogen molar mass", p.hydrogen_molar_mass},
                      {"Henry constant", p.henry_constant},
                      {"Diffusion coefficient", p.diffusion_coefficient, true},
                      {"Temperature", p.temperature},
                      {"Gas constant", p.gas_constant}});
      require(p.regularization > 0 && p.regularization <= 0.1,
              s + "Regularization",
              p.regularization,
              "in (0, 0.1]");
    }


    void
    parse_physics(ParameterHandler &prm, PhysicalParameters &p)
    {
      prm.enter_subsection("Physics");
      for (const PhysicsEntry &entry : physics_entries)
        p.*entry.field = prm.get_double(entry.name);
      check_physics(p);
      prm.leave_subsection();
    }


    void
    check_right_state(const PhysicalParameters &physics,
                      const BoundaryParameters &b)
    {
      // The right state must satisfy 1 - S >= 0, H P^g - beta^l chi >= 0 and
      // (1 - S)(H P^g - beta^l chi) = 0, up to rounding.
      const TwoPhaseModel model(physics);
      const double        Pg =
        b.right_pressure + model.capillary_pressure(b.right_saturation).value;
      const double chi_eq          = model.equilibrium_molar_fraction(Pg);
      const double undersaturation = (chi_eq - b.right_molar_fraction) / chi_eq;
      if (undersaturation < -1e-8 ||
          (b.right_saturation < 1 && undersaturation > 1e-8))
        {
          std::ostringstream message;
          message << "Boundary conditions: the right state (saturation "
                  << b.right_saturation << ", molar fraction "
                  << b.right_molar_fraction
                  << ") violates the phase equilibrium: the molar fraction "
                     "must be at most H P^g / beta^l = "
                  << chi_eq << ", and equal to it where gas is present";
          throw VI::InputError(message.str());
        }
    }


    void
    parse_boundary_conditions(ParameterHandler         &prm,
                              const PhysicalParameters &physics,
                              BoundaryParameters       &b)
    {
      prm.enter_subsection("Boundary conditions");
      const double rate      = prm.get_double("Injection rate");
      const double duration  = prm.get_double("Injection duration");
      b.right_pressure       = prm.get_double("Right pressure");
      b.right_saturation     = prm.get_double("Right saturation");
      b.right_molar_fraction = prm.get_double("Right molar fraction");
      const std::string s    = "Boundary conditions/";
      require_bounds(s,
                     {{"Injection rate", rate, true},
                      {"Injection duration", duration, true},
                      {"Right pressure", b.right_pressure}});
      require(b.right_saturation > physics.residual_liquid_saturation &&
                b.right_saturation <= 1,
              s + "Right saturation",
              b.right_saturation,
              "in (S_lr, 1]");
      require(b.right_molar_fraction >= 0,
              s + "Right molar fraction",
              b.right_molar_fraction,
              ">= 0");
      b.injection_rate     = rate / seconds_per_year;
      b.injection_duration = duration * seconds_per_year;
      check_right_state(physics, b);
      prm.leave_subsection();
    }


    void
    parse_mesh(ParameterHandler &prm, MeshParameters &mesh)
    {
      prm.enter_subsection("Mesh");
      mesh.length  = prm.get_double("Length");
      mesh.n_cells = prm.get_integer("Number of cells");
      require(mesh.length > 0, "Mesh/Length", mesh.length, "> 0");
      prm.leave_subsection();
    }


    /// The output times (years, in [0, T]) in seconds, sorted, without
    /// duplicates.
    void
    parse_output_times(const std::string   &list,
                       const double         T,
                       std::vector<double> &output_times)
    {
      const std::string s = "Time stepping/";
      output_times.clear();
      for (const double year : dealii::Utilities::string_to_double(
             dealii::Utilities::split_string_list(list)))
        {
          if (!(year >= 0 && year <= T))
            {
              std::ostringstream message;
              message << s << "Output times: " << year
                      << " years is outside [0, Final time = " << T
                      << " years]";
              throw VI::InputError(message.str());
            }
          output_times.push_back(year * seconds_per_year);
        }
      std::sort(output_times.begin(), output_times.end());
      output_times.erase(std::unique(output_times.begin(), output_times.end()),
                         output_times.end());
    }


    void
    parse_time_stepping(ParameterHandler &prm, TimeSteppingParameters &t)
    {
      prm.enter_subsection("Time stepping");
      const std::string s      = "Time stepping/";
      const double      T      = prm.get_double("Final time");
      const double      dt     = prm.get_double("Time step");
      const double      dt_min = prm.get_double("Minimal time step");
      t.reduction_factor       = prm.get_double("Reduction factor");
      t.growth_factor          = prm.get_double("Growth factor");
      t.saturation_tolerance   = prm.get_double("Saturation tolerance");
      t.checkpoint_interval    = prm.get_integer("Checkpoint interval");
      t.resume                 = prm.get_bool("Resume");
      require_bounds(s, {{"Final time", T}, {"Time step", dt}});
      require(dt_min > 0 && dt_min <= dt,
              s + "Minimal time step",
              dt_min,
              "in (0, Time step]");
      require(t.reduction_factor > 0 && t.reduction_factor < 1,
              s + "Reduction factor",
              t.reduction_factor,
              "in (0, 1)");
      require(t.growth_factor >= 1,
              s + "Growth factor",
              t.growth_factor,
              ">= 1");
      require(t.saturation_tolerance >= 0,
              s + "Saturation tolerance",
              t.saturation_tolerance,
              ">= 0");
      t.final_time        = T * seconds_per_year;
      t.time_step         = dt * seconds_per_year;
      t.minimal_time_step = dt_min * seconds_per_year;

      parse_output_times(prm.get("Output times"), T, t.output_times);
      prm.leave_subsection();
    }


    void
    parse_nonlinear_solver(ParameterHandler              &prm,
                           VI::NonlinearSolverParameters &nonlinear_solver,
                           std::string                   &package)
    {
      nonlinear_solver.parse(prm, /*mesh_starts=*/false);
      prm.enter_subsection("Nonlinear solver");
      nonlinear_solver.watchdog_steps = prm.get_integer("Watchdog steps");
      package                         = prm.get("Solver");
      prm.leave_subsection();
      if (package == "kinsol")
        {
          if (nonlinear_solver.c_function !=
              VI::ComplementarityFunction::Type::fischer_burmeister)
            throw VI::InputError(
              "Nonlinear solver/Solver = kinsol needs C-function = "
              "fischer-burmeister (KINSOL's line search needs a smooth merit "
              "function)");
          if (nonlinear_solver.strategy == VI::Strategy::adaptive)
            throw VI::InputError(
              "Nonlinear solver/Solver = kinsol supports the strategies exact "
              "and inexact; the adaptive strategy needs Solver = "
              "semismooth-newton");
        }
    }


    /// Solver = direct only with the exact strategy of the nonlinear solver.
    void
    parse_linear_solver(ParameterHandler                    &prm,
                        const VI::NonlinearSolverParameters &nonlinear_solver,
                        VI::LinearSolverParameters          &linear_solver,
                        std::string                         &ordering)
    {
      linear_solver.parse(prm);
      prm.enter_subsection("Linear solver");
      ordering = prm.get("Ordering");
      prm.leave_subsection();
      if (linear_solver.preconditioner != VI::PreconditionerType::ilu)
        throw VI::InputError(
          "Linear solver/Preconditioner = " +
          VI::to_string(linear_solver.preconditioner) +
          ": step-twophase preconditions GMRES with ilu only");
      if (linear_solver.ilu_fill != 0)
        throw VI::InputError(
          "Linear solver/ILU fill = " + std::to_string(linear_solver.ilu_fill) +
          ": step-twophase implements ILU(0) only");
      if (linear_solver.solver == VI::LinearSolverType::direct &&
          nonlinear_solver.strategy != VI::Strategy::exact)
        throw VI::InputError("Nonlinear solver/Strategy = " +
                             VI::to_string(nonlinear_solver.strategy) +
                             " needs Linear solver/Solver = gmres (a direct "
                             "solver has no algebraic error to control)");
    }


    void
    parse_output(ParameterHandler     &prm,
                 VI::OutputParameters &output,
                 unsigned int         &progress_interval)
    {
      output.parse(prm);
      prm.enter_subsection("Output");
      progress_interval = prm.get_integer("Progress interval");
      prm.leave_subsection();
    }
  } // namespace


  void
  Parameters::declare(ParameterHandler &prm)
  {
    declare_physics(prm);
    declare_boundary_conditions(prm);
    declare_mesh(prm);
    declare_time_stepping(prm);
    // The shared sections, with the defaults this problem needs: Newton's
    // balance residuals cannot go below about 1e-10 (rounding in S, through
    // the steep capillary pressure, in the gas fluxes), nor GMRES's
    // relative residual below about 1e-11; the estimators are cheap enough
    // to be checked at every GMRES iteration.
    declare_nonlinear_solver(prm);
    declare_linear_solver(prm);
    declare_output(prm);
  }


  void
  Parameters::parse(ParameterHandler &prm)
  {
    parse_physics(prm, physics);
    parse_boundary_conditions(prm, physics, boundary);
    parse_mesh(prm, mesh);
    parse_time_stepping(prm, time);
    parse_nonlinear_solver(prm, nonlinear_solver, nonlinear_solver_package);
    parse_linear_solver(prm, nonlinear_solver, linear_solver, ordering);
    parse_output(prm, output, progress_interval);
  }
} // namespace StepTwoPhase
