#include <sstream>
#include <vi/errors.h>
#include <vi/parameters.h>

namespace VI
{
  using dealii::ParameterHandler;
  using dealii::Patterns::Anything;
  using dealii::Patterns::Bool;
  using dealii::Patterns::Double;
  using dealii::Patterns::Integer;
  using dealii::Patterns::Selection;

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


  void
  ProblemParameters::declare(ParameterHandler  &prm,
                             const std::string &test_cases,
                             const std::string &default_test_case)
  {
    prm.enter_subsection("Problem");
    {
      prm.declare_entry("Test case",
                        default_test_case,
                        Selection(test_cases),
                        "Data and (where known) exact solution: the seed's "
                        "tests, or 'expression' for the formulas of the "
                        "subsection Expression.");
      prm.declare_entry("mu1",
                        "1",
                        Double(),
                        "Tension of the first membrane (> 0).");
      prm.declare_entry("mu2",
                        "1",
                        Double(),
                        "Tension of the second membrane (> 0).");
      prm.enter_subsection("Expression");
      {
        const std::string variables =
          " Variables x, y; pi and the constants of 'Constants'; muparser "
          "syntax (with atan2 and 'c ? a : b').";
        prm.declare_entry("f1",
                          "0",
                          Anything(),
                          "Force on membrane 1." + variables);
        prm.declare_entry("f2",
                          "0",
                          Anything(),
                          "Force on membrane 2." + variables);
        prm.declare_entry("g1",
                          "0",
                          Anything(),
                          "Dirichlet data of u1." + variables);
        prm.declare_entry("g2",
                          "0",
                          Anything(),
                          "Dirichlet data of u2 (g1 >= g2)." + variables);
        prm.declare_entry("u1",
                          "",
                          Anything(),
                          "Exact u1, or empty if unknown.");
        prm.declare_entry("u2",
                          "",
                          Anything(),
                          "Exact u2, or empty if unknown.");
        prm.declare_entry("lambda",
                          "",
                          Anything(),
                          "Exact multiplier, or empty if unknown.");
        prm.declare_entry("Constants",
                          "",
                          Anything(),
                          "Named constants for the expressions, e.g. "
                          "'R=0.3333, N=6'.");
      }
      prm.leave_subsection();
    }
    prm.leave_subsection();
  }


  void
  ProblemParameters::parse(ParameterHandler &prm)
  {
    prm.enter_subsection("Problem");
    {
      test_case = prm.get("Test case");
      mu1       = prm.get_double("mu1");
      mu2       = prm.get_double("mu2");
      require_positive(mu1, "Problem/mu1");
      require_positive(mu2, "Problem/mu2");
      prm.enter_subsection("Expression");
      {
        expression.f1        = prm.get("f1");
        expression.f2        = prm.get("f2");
        expression.g1        = prm.get("g1");
        expression.g2        = prm.get("g2");
        expression.u1        = prm.get("u1");
        expression.u2        = prm.get("u2");
        expression.lambda    = prm.get("lambda");
        expression.constants = prm.get("Constants");
      }
      prm.leave_subsection();
    }
    prm.leave_subsection();
  }


  void
  MeshParameters::declare(ParameterHandler &prm, const std::string &refinements)
  {
    prm.enter_subsection("Mesh");
    {
      prm.declare_entry("Geometry",
                        "square",
                        Selection("square|disk|L-shape"),
                        "square: (0,1)^2; disk: unit disk centred at the "
                        "origin (curved boundary); L-shape: (-1,1)^2 without "
                        "(0,1)^2.");
      prm.declare_entry("Initial refinements",
                        "3",
                        Integer(0, 20),
                        "Global refinements of the coarse mesh before the "
                        "first cycle.");
      prm.declare_entry("Refinement",
                        "global",
                        Selection(refinements),
                        "How the mesh is refined between cycles.");
      prm.declare_entry("Cycles",
                        "5",
                        Integer(1, 30),
                        "Number of meshes (solve, estimate, refine) to run.");
    }
    prm.leave_subsection();
  }


  void
  MeshParameters::parse(ParameterHandler &prm)
  {
    prm.enter_subsection("Mesh");
    {
      geometry            = prm.get("Geometry");
      initial_refinements = prm.get_integer("Initial refinements");
      refinement          = prm.get("Refinement");
      cycles              = prm.get_integer("Cycles");
    }
    prm.leave_subsection();
  }


  void
  DiscretizationParameters::declare(ParameterHandler  &prm,
                                    const std::string &methods)
  {
    prm.enter_subsection("Discretization");
    {
      prm.declare_entry("Method",
                        "fem",
                        Selection(methods),
                        "Discretisation of the membranes.");
      prm.declare_entry("Polynomial degree",
                        "1",
                        Integer(1, 10),
                        "Polynomial degree p of the approximation.");
    }
    prm.leave_subsection();
  }


  void
  DiscretizationParameters::parse(ParameterHandler &prm)
  {
    prm.enter_subsection("Discretization");
    {
      method = prm.get("Method");
      degree = prm.get_integer("Polynomial degree");
    }
    prm.leave_subsection();
  }


  void
  NonlinearSolverParameters::declare(ParameterHandler  &prm,
                                     const std::string &strategies)
  {
    prm.enter_subsection("Nonlinear solver");
    {
      prm.declare_entry("C-function",
                        "min",
                        Selection("min|fischer-burmeister"),
                        "Complementarity function of the semismooth Newton "
                        "method. Fischer-Burmeister comes with a backtracking "
                        "line search on its merit function.");
      prm.declare_entry("Strategy",
                        "exact",
                        Selection(strategies),
                        "exact: Newton to the tolerance below, each linear "
                        "system solved to round-off.");
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
      prm.declare_entry("Nested iteration",
                        "true",
                        Bool(),
                        "Start Newton on each new mesh from the previous "
                        "mesh's solution; otherwise from zero interior "
                        "values (boundary data imposed) and zero multiplier.");
    }
    prm.leave_subsection();
  }


  void
  NonlinearSolverParameters::parse(ParameterHandler &prm)
  {
    prm.enter_subsection("Nonlinear solver");
    {
      c_function       = prm.get("C-function");
      strategy         = prm.get("Strategy");
      max_iterations   = prm.get_integer("Maximum iterations");
      tolerance        = prm.get_double("Tolerance");
      nested_iteration = prm.get_bool("Nested iteration");
      require_positive(tolerance, "Nonlinear solver/Tolerance");
    }
    prm.leave_subsection();
  }


  void
  LinearSolverParameters::declare(ParameterHandler &prm)
  {
    prm.enter_subsection("Linear solver");
    {
      prm.declare_entry("Solver",
                        "direct",
                        Selection("direct"),
                        "Solver of the linearised systems: direct (sparse LU "
                        "through Trilinos Amesos).");
      prm.declare_entry("Direct solver package",
                        "Amesos_Mumps",
                        Selection("Amesos_Klu|Amesos_Mumps"),
                        "Amesos_Mumps: distributed multifrontal LU; "
                        "Amesos_Klu: serial LU on rank 0 (slow on the "
                        "saddle-point matrices of fine meshes).");
    }
    prm.leave_subsection();
  }


  void
  LinearSolverParameters::parse(ParameterHandler &prm)
  {
    prm.enter_subsection("Linear solver");
    {
      solver         = prm.get("Solver");
      direct_package = prm.get("Direct solver package");
    }
    prm.leave_subsection();
  }


  void
  OutputParameters::declare(ParameterHandler &prm)
  {
    prm.enter_subsection("Output");
    {
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
    prm.leave_subsection();
  }


  void
  OutputParameters::parse(ParameterHandler &prm)
  {
    prm.enter_subsection("Output");
    {
      directory = prm.get("Directory");
      write_vtu = prm.get_bool("Write VTU");
      verbose   = prm.get_bool("Verbose");
      if (directory.empty())
        throw InputError("Output/Directory must not be empty");
    }
    prm.leave_subsection();
  }
} // namespace VI
