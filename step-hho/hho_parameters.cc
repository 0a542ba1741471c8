#include <vi/errors.h>

#include "hho_problem.h"

namespace StepHHO
{
  void
  Parameters::declare(ParameterHandler &prm)
  {
    VI::ProblemParameters::declare(prm,
                                   VI::membrane_test_case_names(),
                                   "seed-smooth");
    VI::MeshParameters::declare(prm);
    // The shared declaration's default method is "fem", which must be among
    // the accepted values; step-hho then narrows "Method" to "hho" (a later
    // declaration of an entry replaces the earlier one).
    VI::DiscretizationParameters::declare(prm, "fem|hho");
    prm.enter_subsection("Discretization");
    {
      prm.declare_entry("Method",
                        "hho",
                        Patterns::Selection("hho"),
                        "Discretisation of the membranes: hho (cell "
                        "polynomials of degree p, face polynomials of degree "
                        "p - 1).");
      prm.declare_entry("Static condensation",
                        "true",
                        Patterns::Bool(),
                        "true: in every Newton step, eliminate the cell "
                        "unknowns (both membranes and the multiplier) cell by "
                        "cell and solve the system on the faces only; false: "
                        "solve the whole linearised system (for comparison; "
                        "needs Linear solver/Solver = direct).");
      prm.declare_entry("Gradient degree",
                        "p",
                        Patterns::Selection("p|p-1"),
                        "Degree k of the gradient reconstruction G_K in "
                        "P_k(K)^2: p as in the seed (exact on P_p on "
                        "parallelograms), or p-1 (exact on P_p on "
                        "parallelograms, and a projection of the gradient on "
                        "any straight-sided cell).");
      prm.declare_entry("Contact nodes",
                        "gauss-padua",
                        Patterns::Selection("gauss-padua|padua"),
                        "The nodes x_I of each cell at which u1 - u2 >= 0 is "
                        "imposed: the checkerboard half of a (p+1) x (p+2) "
                        "grid of Gauss-Legendre points (gauss-padua: all "
                        "interpolatory weights positive), or of "
                        "Chebyshev-Lobatto points (padua: some weights <= 0 "
                        "for p >= 2, which spoils the multiplier).");
    }
    prm.leave_subsection();
    VI::NonlinearSolverParameters::declare(prm, "exact|inexact|adaptive");
    prm.enter_subsection("Nonlinear solver");
    {
      prm.declare_entry("gamma_alg",
                        "0.03",
                        Patterns::Double(0, 1),
                        "Adaptive strategy: CG stops when the algebraic "
                        "estimator is below gamma_alg times the larger of "
                        "the other two. Smaller than the other programs' "
                        "0.3: a CG iteration costs little beside the "
                        "estimate of a Newton step, and rougher directions "
                        "cost Newton steps (doc/step-hho.md).");
    }
    prm.leave_subsection();
    VI::LinearSolverParameters::declare(prm, "direct|cg", "cg");
    prm.enter_subsection("Linear solver");
    {
      prm.declare_entry("Solver",
                        "cg",
                        Patterns::Selection("direct|cg"),
                        "cg: conjugate gradients with the preconditioner "
                        "below on the condensed face system (symmetric "
                        "positive definite); direct: sparse LU through "
                        "Trilinos Amesos, on the face system with static "
                        "condensation and on the whole system without.");
      prm.declare_entry("Preconditioner",
                        "amg",
                        Patterns::Selection("ilu|amg"),
                        "Preconditioner of CG on each of the two face "
                        "systems (the mean and the difference of the "
                        "membranes): amg (Trilinos ML) or ilu (Trilinos "
                        "Ifpack).");
      prm.declare_entry("Check interval",
                        "1",
                        Patterns::Integer(1),
                        "Adaptive strategy: every how many CG iterations "
                        "eta_alg of the current iterate is evaluated (from "
                        "the residual of the face rows: a matrix-vector "
                        "product and a sum over the cells).");
    }
    prm.leave_subsection();
    // Only the switch: the estimate of step-hho has no choices of its own
    // yet (hho_estimate.cc). The adaptive strategy stops CG and Newton with
    // it.
    prm.enter_subsection("Estimators");
    {
      prm.declare_entry("Enabled",
                        "false",
                        Patterns::Bool(),
                        "Compute the guaranteed bound of the energy error "
                        "of the cell polynomials on every mesh (equilibrated "
                        "flux from HHO's own numerical fluxes, Oswald "
                        "potential): the column eta of the convergence "
                        "table.");
    }
    prm.leave_subsection();
    VI::OutputParameters::declare(prm);
  }


  void
  Parameters::parse(ParameterHandler &prm)
  {
    problem.parse(prm);
    mesh.parse(prm);
    discretization.parse(prm);
    prm.enter_subsection("Discretization");
    static_condensation = prm.get_bool("Static condensation");
    contact_nodes       = prm.get("Contact nodes");
    gradient_degree     = prm.get("Gradient degree");
    prm.leave_subsection();
    nonlinear_solver.parse(prm);
    linear_solver.parse(prm);
    prm.enter_subsection("Estimators");
    estimators = prm.get_bool("Enabled");
    prm.leave_subsection();
    output.parse(prm);

    if (nonlinear_solver.initial_guess == VI::InitialGuess::data)
      throw VI::InputError(
        "Nonlinear solver/Initial guess = data is implemented for "
        "step-membranes; step-hho starts from zero (set it to zero)");
    VI::require_estimators_where_read(&mesh,
                                      nonlinear_solver.strategy,
                                      estimators);
    if (linear_solver.solver == VI::LinearSolverType::cg &&
        !static_condensation)
      throw VI::InputError(
        "Linear solver/Solver = cg needs Discretization/Static condensation "
        "= true: without condensation the Newton system is a nonsymmetric "
        "saddle-point system (use Solver = direct)");
  }
} // namespace StepHHO
