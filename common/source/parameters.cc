#include <deal.II/base/utilities.h>

#include <vi/errors.h>
#include <vi/parameters.h>
#include <vi/spellings.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <sstream>

namespace VI
{
  using dealii::ParameterHandler;
  namespace numbers   = dealii::numbers;
  namespace types     = dealii::types;
  namespace Utilities = dealii::Utilities;
  // The patterns of the declarations: Double(), Selection("a|b"), ...
  using namespace dealii::Patterns;

  ParameterSubsection::ParameterSubsection(ParameterHandler  &prm,
                                           const std::string &name)
      : prm(prm)
  {
    prm.enter_subsection(name);
  }


  ParameterSubsection::~ParameterSubsection()
  {
    prm.leave_subsection();
  }


  namespace
  {
    std::string parameter_directory;
  }


  void
  set_parameter_directory(const std::string &directory)
  {
    parameter_directory = directory;
  }


  std::string
  parameter_path(const std::string &path)
  {
    if (path.empty() || parameter_directory.empty() ||
        std::filesystem::path(path).is_absolute())
      return path;
    return (std::filesystem::path(parameter_directory) / path).string();
  }


  namespace
  {
    // The .prm spelling of each choice.
    const Spellings<Method>   method_spellings   = {{Method::fem, "fem"},
                                                    {Method::sipg, "sipg"},
                                                    {Method::nipg, "nipg"},
                                                    {Method::iipg, "iipg"},
                                                    {Method::hho, "hho"}};
    const Spellings<Strategy> strategy_spellings = {
      {Strategy::exact, "exact"},
      {Strategy::inexact, "inexact"},
      {Strategy::adaptive, "adaptive"}};
    const Spellings<ContinuationMethod> continuation_method_spellings = {
      {ContinuationMethod::interior_point, "interior point"},
      {ContinuationMethod::smoothing, "smoothing"}};
    const Spellings<InitialGuess> initial_guess_spellings =
      {{InitialGuess::zero, "zero"}, {InitialGuess::data, "data"}};
    const Spellings<LinearSolverType> linear_solver_spellings = {
      {LinearSolverType::direct, "direct"},
      {LinearSolverType::gmres, "gmres"},
      {LinearSolverType::cg, "cg"}};
    const Spellings<PreconditionerType> preconditioner_spellings =
      {{PreconditionerType::ilu, "ilu"}, {PreconditionerType::amg, "amg"}};
    const Spellings<Refinement> refinement_spellings =
      {{Refinement::global, "global"}, {Refinement::adaptive, "adaptive"}};
    const Spellings<Marking> marking_spellings = {{Marking::dorfler, "dorfler"},
                                                  {Marking::fixed_fraction,
                                                   "fixed-fraction"}};
    using TransmittedLoad = EstimatorParameters::TransmittedLoad;
    using Multiplier      = EstimatorParameters::Multiplier;
    using FluxDegree      = EstimatorParameters::FluxDegree;
    const Spellings<FluxDegree> flux_degree_spellings = {{FluxDegree::p, "p"},
                                                         {FluxDegree::p_minus_1,
                                                          "p-1"}};
    const Spellings<Multiplier> multiplier_spellings  = {
       {Multiplier::contact_cells, "contact cells"},
       {Multiplier::conforming, "conforming"}};
    const Spellings<TransmittedLoad> transmitted_load_spellings = {
      {TransmittedLoad::automatic, "auto"},
      {TransmittedLoad::always, "always"},
      {TransmittedLoad::never, "never"}};

    // A value that has passed its Selection pattern.
    template <typename Enum>
    Enum
    parse_choice(const Spellings<Enum> &table, const std::string &name)
    {
      if (const auto value = value_spelt(table, name))
        return *value;
      throw InputError("unknown choice '" + name + "'");
    }
  } // namespace


  std::string
  to_string(const Method method)
  {
    return spelling_of(method_spellings, method);
  }


  std::string
  to_string(const Strategy strategy)
  {
    return spelling_of(strategy_spellings, strategy);
  }


  std::string
  to_string(const LinearSolverType solver)
  {
    return spelling_of(linear_solver_spellings, solver);
  }


  std::string
  to_string(const PreconditionerType preconditioner)
  {
    return spelling_of(preconditioner_spellings, preconditioner);
  }


  namespace
  {
    void
    require_positive(const double value, const std::string &name)
    {
      if (!(value > 0.))
        {
          std::ostringstream message;
          message << name << " = " << value << " must be positive";
          throw InputError(message.str());
        }
    }
  } // namespace


  namespace
  {
    // The entries of Problem/Expression: the data and, where known, the
    // exact solution. The documentation of the data's formulas goes on
    // with the variables they may use.
    struct ExpressionEntry
    {
      const char *name;
      std::string ExpressionParameters::*field;
      const char                        *default_value;
      const char                        *documentation;
      bool                               is_formula;
    };

    const ExpressionEntry expression_entries[] = {
      {"f1", &ExpressionParameters::f1, "0", "Force on membrane 1.", true},
      {"f2", &ExpressionParameters::f2, "0", "Force on membrane 2.", true},
      {"g1", &ExpressionParameters::g1, "0", "Dirichlet data of u1.", true},
      {"g2",
       &ExpressionParameters::g2,
       "0",
       "Dirichlet data of u2 (g1 >= g2).",
       true},
      {"u1",
       &ExpressionParameters::u1,
       "",
       "Exact u1, or empty if unknown.",
       false},
      {"u2",
       &ExpressionParameters::u2,
       "",
       "Exact u2, or empty if unknown.",
       false},
      {"lambda",
       &ExpressionParameters::lambda,
       "",
       "Exact multiplier, or empty if unknown.",
       false},
      {"obstacle",
       &ExpressionParameters::obstacle,
       "",
       "With Model = obstacle: the rigid obstacle under membrane 1 (u1 >= "
       "obstacle). A function, not necessarily continuous.",
       true},
      {"Constants",
       &ExpressionParameters::constants,
       "",
       "Named constants for the expressions, e.g. 'R=0.3333, N=6'.",
       false}};
  } // namespace


  void
  ProblemParameters::declare(ParameterHandler  &prm,
                             const std::string &test_cases,
                             const std::string &default_test_case,
                             const std::string &variable_names)
  {
    const ParameterSubsection section(prm, "Problem");
    prm.declare_entry("Test case",
                      default_test_case,
                      Selection(test_cases),
                      "Data and (where known) exact solution: the seed's "
                      "tests, or 'expression' for the formulas of the "
                      "subsection Expression.");
    prm.declare_entry("Model",
                      "two-membranes",
                      Selection("two-membranes|obstacle"),
                      "two-membranes: membrane 1 over membrane 2; obstacle: "
                      "membrane 1 (mu1, f1, g1, exact u1 and lambda) over "
                      "the rigid obstacle Expression/obstacle (Test case = "
                      "expression); membrane 2's entries are then not "
                      "used.");
    prm.declare_entry(
      "Smooth obstacle",
      "false",
      Bool(),
      "Model = obstacle, step-membranes: declare the obstacle twice "
      "differentiable where the discrete solution dips below it. The "
      "estimate then also takes a bound that adds the error where the "
      "membrane is free and the interpolation error of the obstacle in "
      "quadrature (doc/reference.md, 'The estimate over an obstacle'). "
      "With a concave kink of the obstacle in the contact set that bound "
      "need not hold: leave it false.");
    prm.declare_entry("mu1",
                      "1",
                      Double(),
                      "Tension of the first membrane (> 0).");
    prm.declare_entry("mu2",
                      "1",
                      Double(),
                      "Tension of the second membrane (> 0).");
    BoundaryParameters::declare(prm);
    {
      const ParameterSubsection expression_section(prm, "Expression");
      const std::string         variables =
        " Variables " + variable_names +
        "; pi and the constants of 'Constants'; muparser "
        "syntax (with atan2 and 'c ? a : b').";
      for (const ExpressionEntry &entry : expression_entries)
        prm.declare_entry(entry.name,
                          entry.default_value,
                          Anything(),
                          std::string(entry.documentation) +
                            (entry.is_formula ? variables : ""));
    }
  }


  void
  ProblemParameters::parse(ParameterHandler &prm)
  {
    const ParameterSubsection section(prm, "Problem");
    test_case = prm.get("Test case");
    model =
      prm.get("Model") == "obstacle" ? Model::obstacle : Model::two_membranes;
    mu1             = prm.get_double("mu1");
    mu2             = prm.get_double("mu2");
    smooth_obstacle = prm.get_bool("Smooth obstacle");
    if (smooth_obstacle && model != Model::obstacle)
      throw InputError("Problem/Smooth obstacle = true is for Model = "
                       "obstacle; remove it");
    require_positive(mu1, "Problem/mu1");
    require_positive(mu2, "Problem/mu2");
    boundary.parse(prm);
    {
      const ParameterSubsection expression_section(prm, "Expression");
      for (const ExpressionEntry &entry : expression_entries)
        expression.*entry.field = prm.get(entry.name);
    }
  }


  void
  BoundaryParameters::declare(ParameterHandler &prm)
  {
    prm.declare_entry("Dirichlet boundary ids",
                      "all",
                      Anything(),
                      "Where the membranes are clamped (u_alpha = g_alpha): "
                      "all, or a comma-separated list of boundary ids; they "
                      "are free (zero normal derivative) on the other "
                      "boundary faces. The ids of each geometry are listed "
                      "in doc/step-membranes.md (a mesh file's: its "
                      "physical line tags).");
    prm.declare_entry("Friedrichs constant",
                      "auto",
                      Anything(),
                      "An upper bound of C_F, |v| <= C_F |grad v| for v "
                      "vanishing on the clamped boundary, which the "
                      "estimates take: auto (known for every geometry "
                      "clamped on its whole boundary, and for the square "
                      "clamped on some sides), or a number > 0.");
  }


  void
  BoundaryParameters::parse(ParameterHandler &prm)
  {
    const std::string ids = Utilities::trim(prm.get("Dirichlet boundary ids"));
    clamped_everywhere    = ids == "all";
    dirichlet_ids.clear();
    if (!clamped_everywhere)
      for (const std::string &id : Utilities::split_string_list(ids, ','))
        {
          char      *end   = nullptr;
          const long value = std::strtol(id.c_str(), &end, 10);
          if (id.empty() || *end != '\0' || value < 0 ||
              value >= numbers::internal_face_boundary_id)
            throw InputError("Problem/Dirichlet boundary ids: <" + ids +
                             "> is not 'all' nor a list of boundary ids "
                             "(integers from 0 to 254)");
          dirichlet_ids.push_back(static_cast<types::boundary_id>(value));
        }
    const std::string constant =
      Utilities::trim(prm.get("Friedrichs constant"));
    friedrichs_constant = 0;
    if (constant != "auto")
      {
        char *end           = nullptr;
        friedrichs_constant = std::strtod(constant.c_str(), &end);
        if (constant.empty() || *end != '\0' || !(friedrichs_constant > 0) ||
            !std::isfinite(friedrichs_constant))
          throw InputError("Problem/Friedrichs constant: <" + constant +
                           "> is not 'auto' nor a number > 0");
      }
  }


  void
  DomainParameters::declare(ParameterHandler  &prm,
                            const std::string &default_geometry,
                            const std::string &default_refinements,
                            const std::string &refinements_doc)
  {
    const ParameterSubsection section(prm, "Mesh");
    prm.declare_entry("Geometry",
                      default_geometry,
                      Selection("square|disk|L-shape|square-circle|file"),
                      "square: (0,1)^2; disk: unit disk centred at the "
                      "origin (curved boundary); L-shape: (-1,1)^2 without "
                      "(0,1)^2; square-circle: (0,1)^2 with the circle of "
                      "radius 1/3 about (0.5, 0.5), where the seed tests' "
                      "contact set ends, as a line of the mesh (curved "
                      "cells); file: the mesh of Mesh/File.");
    prm.declare_entry("File",
                      "",
                      Anything(),
                      "With Geometry = file: the mesh, relative to the "
                      "parameter file's folder; Gmsh .msh (its physical "
                      "line tags become boundary ids, its physical surface "
                      "tags material ids), or another format deal.II's "
                      "GridIn reads (.inp, .vtk, .unv, ...), with "
                      "straight-sided quadrilaterals.");
    prm.declare_entry("Initial refinements",
                      default_refinements,
                      Integer(0, 20),
                      refinements_doc);
  }


  void
  DomainParameters::parse(ParameterHandler &prm)
  {
    const ParameterSubsection section(prm, "Mesh");
    geometry            = prm.get("Geometry");
    file                = parameter_path(prm.get("File"));
    initial_refinements = prm.get_integer("Initial refinements");
    if (geometry == "file" && file.empty())
      throw InputError("Mesh/File: Mesh/Geometry = file needs a mesh file");
  }


  void
  MeshParameters::declare(ParameterHandler &prm)
  {
    DomainParameters::declare(prm,
                              "square",
                              "3",
                              "Global refinements of the coarse mesh before "
                              "the first cycle.");
    const ParameterSubsection section(prm, "Mesh");
    prm.declare_entry("Refinement",
                      "global",
                      Selection(all_spellings(refinement_spellings)),
                      "How the mesh is refined between cycles: every "
                      "cell (global), or the cells marked by the "
                      "estimators (adaptive).");
    prm.declare_entry("Marking",
                      "dorfler",
                      Selection(all_spellings(marking_spellings)),
                      "Adaptive refinement: dorfler refines the fewest "
                      "cells that carry the Refinement fraction of the "
                      "squared estimate; fixed-fraction refines the "
                      "Refinement fraction of the cells with the largest "
                      "indicators. Both also refine the cells whose "
                      "indicators equal that of a refined cell to "
                      "round-off.");
    prm.declare_entry("Refinement fraction",
                      "0.5",
                      Double(0., 1.),
                      "theta of the marking (see Marking), in (0, 1].");
    prm.declare_entry("Cycles",
                      "5",
                      Integer(1, 30),
                      "Number of meshes (solve, estimate, refine) to run.");
  }


  void
  MeshParameters::parse(ParameterHandler &prm)
  {
    DomainParameters::parse(prm);
    const ParameterSubsection section(prm, "Mesh");
    refinement = parse_choice(refinement_spellings, prm.get("Refinement"));
    marking    = parse_choice(marking_spellings, prm.get("Marking"));
    refinement_fraction = prm.get_double("Refinement fraction");
    if (refinement_fraction <= 0.)
      throw InputError("Mesh/Refinement fraction must be in (0, 1]; got " +
                       prm.get("Refinement fraction"));
    cycles = prm.get_integer("Cycles");
  }


  void
  require_estimators_where_read(const MeshParameters *mesh,
                                const Strategy        strategy,
                                const bool            estimators_enabled)
  {
    if (estimators_enabled)
      return;
    if (mesh != nullptr && mesh->refinement == Refinement::adaptive)
      throw InputError("Mesh/Refinement = adaptive marks the cells with the "
                       "estimators: set Estimators/Enabled = true");
    if (strategy == Strategy::adaptive)
      throw InputError("Nonlinear solver/Strategy = adaptive stops the "
                       "solvers with the estimators: set "
                       "Estimators/Enabled = true");
  }


  void
  DiscretizationParameters::declare(ParameterHandler  &prm,
                                    const std::string &methods)
  {
    const ParameterSubsection section(prm, "Discretization");
    prm.declare_entry("Method",
                      "fem",
                      Selection(methods),
                      "Discretisation of the membranes.");
    prm.declare_entry("Polynomial degree",
                      "1",
                      Integer(1, 10),
                      "Polynomial degree p of the approximation.");
  }


  void
  DiscretizationParameters::parse(ParameterHandler &prm)
  {
    const ParameterSubsection section(prm, "Discretization");
    method = parse_choice(method_spellings, prm.get("Method"));
    degree = prm.get_integer("Polynomial degree");
  }


  void
  NonlinearSolverParameters::declare(ParameterHandler  &prm,
                                     const std::string &strategies,
                                     const bool         mesh_starts)
  {
    const ParameterSubsection section(prm, "Nonlinear solver");
    prm.declare_entry("C-function",
                      "min",
                      Selection("min|fischer-burmeister"),
                      "Complementarity function of the semismooth Newton "
                      "method. In step-twophase, Fischer-Burmeister comes "
                      "with a backtracking line search on its merit "
                      "function.");
    prm.declare_entry("Strategy",
                      "exact",
                      Selection(strategies),
                      "exact: Newton to the tolerance below, each linear "
                      "system solved to 'Linear solver/Tolerance'; "
                      "inexact: the linear solver stops at the relative "
                      "residual 'Forcing term'; adaptive: the linear "
                      "solver stops when eta_alg <= gamma_alg "
                      "max(eta_disc, eta_lin), Newton when eta_lin <= "
                      "gamma_lin eta_disc.");
    prm.declare_entry("gamma_lin",
                      "0.3",
                      Double(0, 1),
                      "Adaptive strategy: Newton stops when the "
                      "linearisation estimator is below gamma_lin times "
                      "the discretisation estimator.");
    prm.declare_entry("gamma_alg",
                      "0.3",
                      Double(0, 1),
                      "Adaptive strategy: the linear solver stops when the "
                      "algebraic estimator is below gamma_alg times the "
                      "larger of the other two.");
    prm.declare_entry("Forcing term",
                      "1e-2",
                      Double(0, 1),
                      "Inexact strategy: relative residual at which the "
                      "linear solver stops in every Newton step.");
    prm.declare_entry("Maximum iterations",
                      "50",
                      Integer(1),
                      "Newton iterations allowed per mesh before the run "
                      "fails.");
    prm.declare_entry("Tolerance",
                      "1e-10",
                      Double(0),
                      "Newton stops when both dimensionless residuals "
                      "(balance equations relative to the load, "
                      "complementarity relative to the size of u and "
                      "lambda) are below it.");
    prm.declare_entry("Continuation",
                      "true",
                      Bool(),
                      "When the active set stalls (three steps in a row "
                      "that switch rows at a steady pace and shrink the "
                      "complementarity residual by less than half, six "
                      "under the adaptive strategy; with inexact "
                      "directions also three over which it does not "
                      "halve, with exact ones six that cycle), "
                      "follow the central path gap x multiplier = mu^2 "
                      "to the solution instead (Continuation method; "
                      "doc/reference.md, Continuation). false: plain "
                      "semismooth Newton throughout. step-twophase has no "
                      "central path and globalises Fischer-Burmeister by a "
                      "line search (Watchdog steps).");
    prm.declare_entry(
      "Continuation method",
      "interior point",
      Selection(all_spellings(continuation_method_spellings)),
      "interior point: a primal-dual interior-point method (Mehrotra's "
      "predictor-corrector, gaps and multipliers kept positive); "
      "smoothing: semismooth Newton on the smoothed C-function, mu "
      "lowered with the length of each step.");
    if (!mesh_starts)
      return;
    prm.declare_entry("Nested iteration",
                      "true",
                      Bool(),
                      "Start Newton on each new mesh from the previous "
                      "mesh's solution; otherwise (and on the first mesh) "
                      "from the initial guess below.");
    prm.declare_entry("Initial guess",
                      "zero",
                      Selection("zero|data"),
                      "zero: zero interior values and multiplier (the "
                      "boundary data imposed); data: u1h, u2h interpolate "
                      "the formulas of g1, g2 in the whole domain and the "
                      "multiplier is zero (for constant boundary data "
                      "the X0 = (g, 0, 0) of [DMV20]).");
  }


  void
  NonlinearSolverParameters::parse(ParameterHandler &prm,
                                   const bool        mesh_starts)
  {
    const ParameterSubsection section(prm, "Nonlinear solver");
    c_function =
      ComplementarityFunction::from_name(prm.get("C-function")).type();
    strategy            = parse_choice(strategy_spellings, prm.get("Strategy"));
    gamma_lin           = prm.get_double("gamma_lin");
    gamma_alg           = prm.get_double("gamma_alg");
    forcing_term        = prm.get_double("Forcing term");
    max_iterations      = prm.get_integer("Maximum iterations");
    tolerance           = prm.get_double("Tolerance");
    continuation        = prm.get_bool("Continuation");
    continuation_method = parse_choice(continuation_method_spellings,
                                       prm.get("Continuation method"));
    if (mesh_starts)
      {
        nested_iteration = prm.get_bool("Nested iteration");
        initial_guess =
          parse_choice(initial_guess_spellings, prm.get("Initial guess"));
      }
    require_positive(tolerance, "Nonlinear solver/Tolerance");
    require_positive(gamma_lin, "Nonlinear solver/gamma_lin");
    require_positive(gamma_alg, "Nonlinear solver/gamma_alg");
    require_positive(forcing_term, "Nonlinear solver/Forcing term");
  }


  bool
  NonlinearSolverParameters::algebraic_error_small(const double eta_disc,
                                                   const double eta_lin,
                                                   const double eta_alg) const
  {
    return eta_alg <= algebraic_threshold(eta_disc, eta_lin);
  }


  double
  NonlinearSolverParameters::algebraic_threshold(const double eta_disc,
                                                 const double eta_lin) const
  {
    return gamma_alg * std::max(eta_disc, eta_lin);
  }


  bool
  NonlinearSolverParameters::linearisation_error_small(
    const double eta_disc,
    const double eta_lin) const
  {
    return eta_lin <= gamma_lin * eta_disc;
  }


  double
  linear_tolerance(const NonlinearSolverParameters &nonlinear,
                   const LinearSolverParameters    &linear)
  {
    return nonlinear.strategy == Strategy::inexact ? nonlinear.forcing_term :
                                                     linear.tolerance;
  }


  void
  LinearSolverParameters::declare(ParameterHandler  &prm,
                                  const std::string &solvers,
                                  const std::string &default_solver)
  {
    const ParameterSubsection section(prm, "Linear solver");
    prm.declare_entry("Solver",
                      default_solver,
                      Selection(solvers),
                      "direct: sparse LU through Trilinos Amesos; gmres: "
                      "GMRES with the preconditioner below.");
    prm.declare_entry("Direct solver package",
                      "Amesos_Mumps",
                      Selection("Amesos_Klu|Amesos_Mumps"),
                      "Amesos_Mumps: distributed multifrontal LU; "
                      "Amesos_Klu: serial LU on rank 0 (slow on the "
                      "saddle-point matrices of fine meshes).");
    prm.declare_entry("Preconditioner",
                      "ilu",
                      Selection("ilu|amg"),
                      "Preconditioner of GMRES: ilu (Trilinos Ifpack, on "
                      "the whole system) or amg (Trilinos ML on the "
                      "system without multiplier rows).");
    prm.declare_entry("Tolerance",
                      "1e-12",
                      Double(0, 1),
                      "Relative residual of the linear solves of the "
                      "exact strategy.");
    prm.declare_entry("Maximum iterations",
                      "2000",
                      Integer(1),
                      "GMRES iterations allowed per linear solve.");
    prm.declare_entry("Krylov dimension",
                      "200",
                      Integer(1),
                      "GMRES restart length.");
    prm.declare_entry("Check interval",
                      "10",
                      Integer(1),
                      "Every how many GMRES iterations the estimators of "
                      "the current iterate are evaluated (adaptive "
                      "strategy): at most this many apart with 'Predict "
                      "checks'.");
    prm.declare_entry("Predict checks",
                      "true",
                      Bool(),
                      "Adaptive strategy: also evaluate the estimators where "
                      "GMRES's residual, scaled by eta_alg / residual of the "
                      "last check, predicts that eta_alg passes its test "
                      "(false: every 'Check interval' iterations, as in "
                      "[DMV20]).");
    prm.declare_entry("ILU fill",
                      "0",
                      Integer(0, 10),
                      "Fill level k of ILU(k).");
  }


  void
  LinearSolverParameters::parse(ParameterHandler &prm)
  {
    const ParameterSubsection section(prm, "Linear solver");
    solver         = parse_choice(linear_solver_spellings, prm.get("Solver"));
    direct_package = prm.get("Direct solver package");
    preconditioner =
      parse_choice(preconditioner_spellings, prm.get("Preconditioner"));
    tolerance        = prm.get_double("Tolerance");
    max_iterations   = prm.get_integer("Maximum iterations");
    krylov_dimension = prm.get_integer("Krylov dimension");
    check_interval   = prm.get_integer("Check interval");
    predict_checks   = prm.get_bool("Predict checks");
    ilu_fill         = prm.get_integer("ILU fill");
    require_positive(tolerance, "Linear solver/Tolerance");
  }


  void
  EstimatorParameters::declare(ParameterHandler &prm)
  {
    const ParameterSubsection section(prm, "Estimators");
    prm.declare_entry("Enabled",
                      "true",
                      Bool(),
                      "Compute the a posteriori error estimate (flux "
                      "reconstruction and estimators) of every Newton "
                      "iterate; required by the adaptive strategy.");
    prm.declare_entry("At every check",
                      "true",
                      Bool(),
                      "Also estimate the iterates of the linear solver "
                      "every 'Linear solver/Check interval' iterations "
                      "(always done by the adaptive strategy; costly for "
                      "the exact one, but it draws the estimators against "
                      "the linear iterations).");
    prm.declare_entry(
      "Multiplier",
      "contact cells",
      Selection(all_spellings(multiplier_spellings)),
      "The multiplier the estimate works with, for FEM of degree p >= 2 "
      "(p = 1 keeps its mass-lumped nodal one, and takes the contact cells' "
      "with the transmitted load; dG its cellwise one): "
      "'contact cells' shares "
      "each nodal moment of lambda_h among the cells at the node, on the "
      "contact cells where there are some, as a cellwise Q1 function; "
      "'conforming' is the finite element function M^(-1) m, which "
      "spreads a jump of the multiplier into the cells outside the "
      "contact set (doc/estimators.md).");
    prm.declare_entry(
      "Flux degree",
      "p",
      Selection(all_spellings(flux_degree_spellings)),
      "The Raviart-Thomas space of the equilibrated fluxes for elements "
      "of degree p: 'p', RT_p x Q_p as in "
      "[DMV20]; 'p-1', RT_(p-1) x Q_(p-1), whose patch problems are "
      "smaller and cheaper to set up and solve, and the quadrature of "
      "the problem and the estimate has p + 1 Gauss points per direction "
      "instead of p + 3 (for the conforming method; both rounded up to "
      "even). The flux is then "
      "equilibrated in the Q_(p-1) moments: the bound stays guaranteed, "
      "and the residual estimator takes the projection error of the "
      "source, which is of higher order. Meant for meshes without "
      "hanging nodes: with Q1 on adaptive meshes the estimate was found "
      "much less sharp, the excess at the hanging nodes "
      "(doc/estimators.md).");
    prm.declare_entry(
      "Equilibrated dual norms",
      "",
      MultipleSelection("undershoots|remainder"),
      "Terms of the estimate (FEM in step-membranes) whose dual norm "
      "||m||_{-1} = sup (m, v) / |grad v| over H^1_0 is bounded by "
      "equilibration (a Poisson solve and a flux reconstruction of one "
      "field per term and estimate) instead of by C_F |m| (Friedrichs), "
      "which is pessimistic for m concentrated on a band or oscillating "
      "(doc/estimators.md): 'undershoots', the cell means of the "
      "undershoots lambda_h < 0 of a Newton iterate; 'remainder', the "
      "residuals rho_alpha that the look-ahead leaves (the algebraic "
      "remainder; at GMRES checks only where it may decide the adaptive "
      "strategy's test). Empty: Friedrichs for both.");
    prm.declare_entry(
      "Defer fluxes",
      "true",
      Bool(),
      "Adaptive strategy (FEM in step-membranes): at a check of GMRES, "
      "first evaluate the terms that need no equilibrated flux (eta_alg "
      "from above with Friedrichs' bound of the residual, eta_lin from "
      "below without its cross term). If they show that GMRES may stop "
      "and that Newton must go on (eta_lin above gamma_lin times the "
      "eta_disc predicted from the last complete estimate, scaled by "
      "(N_last / N)^(p/d) with N the unknowns per field), the flux "
      "reconstruction of that iterate is skipped. Every iterate Newton "
      "stops at is estimated completely; a wrong prediction costs one "
      "more Newton step, never accuracy (doc/estimators.md).");
    prm.declare_entry(
      "Sharpen final estimate",
      "false",
      Bool(),
      "FEM in step-membranes: when the solve on a mesh has ended, "
      "estimate its iterate once more with both dual norms of 'Equilibrated "
      "dual norms' (undershoots, remainder) bounded by equilibration, and "
      "report the smallest of the guaranteed bounds (table, summary.json, "
      "marking); with 'Transmitted load = auto' also with the other "
      "multiplier (with the transmitted load or without). The stopping "
      "tests keep their estimates; the cost is one more reconstruction (two "
      "with auto) and up to three Poisson solves each per mesh, only where "
      "Friedrichs' bound of a term exceeds 1 % of the discretisation "
      "estimator.");
    prm.declare_entry(
      "Transmitted load",
      "auto",
      Selection(all_spellings(transmitted_load_spellings)),
      "Whether the multiplier of the estimate carries, on the cells at the "
      "contact set, the load the contact transmits where the membranes "
      "move together, (mu1 l2 - mu2 l1) / (mu1 + mu2) with the loads l = "
      "f (l = f - d_t u_h in step-parabolic); for FEM of degree p >= 2 "
      "only with Multiplier = contact cells; the dG methods also join the "
      "membranes of the cone reconstruction at the free boundary. This "
      "makes the bound robust in the tension ratio (doc/reference.md, 'A "
      "bound robust in the tensions'); with equal tensions the bound is "
      "about the same on fine meshes, less sharp on the coarsest. 'auto': "
      "when the tensions are more than 10 times apart, in step-parabolic "
      "also for p >= 2; a sharpened final estimate (FEM) takes the smaller "
      "of the two.");
  }


  void
  EstimatorParameters::parse(ParameterHandler &prm)
  {
    const ParameterSubsection section(prm, "Estimators");
    enabled     = prm.get_bool("Enabled");
    every_check = prm.get_bool("At every check");
    multiplier  = parse_choice(multiplier_spellings, prm.get("Multiplier"));
    flux_degree = parse_choice(flux_degree_spellings, prm.get("Flux degree"));
    const auto dual_norms =
      dealii::Utilities::split_string_list(prm.get("Equilibrated dual norms"));
    const auto has = [&](const std::string &term) {
      return std::find(dual_norms.begin(), dual_norms.end(), term) !=
             dual_norms.end();
    };
    dual_norm_undershoots = has("undershoots");
    dual_norm_remainder   = has("remainder");
    defer_fluxes          = prm.get_bool("Defer fluxes");
    sharpen_final         = prm.get_bool("Sharpen final estimate");
    transmitted_load =
      parse_choice(transmitted_load_spellings, prm.get("Transmitted load"));
  }


  bool
  EstimatorParameters::transmits_load(const double mu1, const double mu2) const
  {
    return transmitted_load == TransmittedLoad::always ||
           (transmitted_load == TransmittedLoad::automatic &&
            std::max(mu1, mu2) > 10. * std::min(mu1, mu2));
  }


  bool
  EstimatorParameters::uses_transmitted_load(
    const double       mu1,
    const double       mu2,
    const unsigned int p,
    const bool         every_contact_cell) const
  {
    // (p >= 2: with the cellwise multiplier, on whose contact cells the
    // moments are shared)
    return (p == 1 || multiplier == Multiplier::contact_cells) &&
           (transmits_load(mu1, mu2) ||
            (transmitted_load == TransmittedLoad::automatic &&
             every_contact_cell && p >= 2));
  }


  void
  OutputParameters::declare(ParameterHandler &prm)
  {
    const ParameterSubsection section(prm, "Output");
    prm.declare_entry("Directory",
                      "output",
                      Anything(),
                      "Where VTU/PVTU files, the convergence table and "
                      "summary.json are written (created if needed).");
    prm.declare_entry("Write VTU",
                      "true",
                      Bool(),
                      "Write the solution of every cycle for ParaView.");
    prm.declare_entry("Verbose",
                      "false",
                      Bool(),
                      "Print every Newton iteration.");
  }


  void
  OutputParameters::parse(ParameterHandler &prm)
  {
    const ParameterSubsection section(prm, "Output");
    directory = prm.get("Directory");
    write_vtu = prm.get_bool("Write VTU");
    verbose   = prm.get_bool("Verbose");
    if (directory.empty())
      throw InputError("Output/Directory must not be empty");
  }
} // namespace VI
