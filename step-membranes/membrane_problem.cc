// step-membranes, conforming Q_p: the problem, its data checks and mesh, and
// what a cycle measured (the loop over the meshes is StationaryProblem::run()).

#include "membrane_problem.h"

#include <deal.II/base/utilities.h>
#include <deal.II/fe/fe_values.h>
#include <deal.II/fe/mapping_q.h>

#include <vi/errors.h>
#include <vi/nodal_fields.h>
#include <vi/program.h>

#include <iomanip>
#include <sstream>

namespace StepMembranes
{
  template <int dim>
  MembraneProblem<dim>::MembraneProblem(const Parameters &parameters,
                                        ParameterHandler &prm,
                                        const MPI_Comm    comm)
      : StationaryProblem("step-membranes", parameters, prm, comm)
      , Discretisation(VI::Domain(parameters.mesh, parameters.problem.boundary),
                       parameters.discretization.degree,
                       parameters.estimators.flux_degree_for(
                         parameters.discretization.degree),
                       comm)
      , parameters(parameters)
      , data(VI::make_membrane_data<dim>(parameters.problem,
                                         domain.template center<dim>()))
      , C(VI::ComplementarityFunction(parameters.nonlinear_solver.c_function))
      , contact_system(C, parameters, timer)
      , multiplier_function(make_multiplier_function(contact_system))
      , stopping(parameters.nonlinear_solver,
                 stopping_hooks(),
                 parameters.output.verbose ? &pcout : nullptr)
  {
  }


  template <int dim>
  void
  MembraneProblem<dim>::make_grid()
  {
    Discretisation::make_grid(parameters.mesh.initial_refinements);
  }


  // The data must be finite and admit a solution: g1 >= g2 on the boundary
  // (otherwise the constraint u1 >= u2 contradicts the boundary condition).
  // Checked on the first mesh (forces at the quadrature points, boundary
  // data at the boundary support points) before anything is written.
  template <int dim>
  void
  MembraneProblem<dim>::check_data() const
  {
    VI::check_membrane_data(
      data, triangulation, domain, *mapping, fe, quadrature);
  }


  template <int dim>
  std::string
  MembraneProblem<dim>::description() const
  {
    std::ostringstream line;
    line << "Test case " << data.name << " on the " << domain.name() << ", Q"
         << fe.degree << " elements, " << solver_name() << " "
         << VI::describe_solvers(parameters.nonlinear_solver,
                                 parameters.linear_solver)
         << (parameters.estimators.enabled ? ", estimators on" : "");
    return line.str();
  }


  template <int dim>
  std::string
  MembraneProblem<dim>::solver_name() const
  {
    return parameters.nonlinear_method ==
               Parameters::NonlinearMethod::petsc_vi ?
             "PETSc SNES VI (vinewton" + parameters.petsc_vi_type + ")" :
             "Newton-" + C.name();
  }


  template <int dim>
  VI::CycleNumbers
  MembraneProblem<dim>::cycle_numbers(const unsigned int cycle) const
  {
    VI::CycleNumbers numbers =
      measured(cycle,
               triangulation.n_global_active_cells(),
               dof_handler.n_dofs(),
               solver_name(),
               VI::counted_linear_solver(parameters.linear_solver));
    if (final_estimate)
      numbers.estimate = final_estimate->eta;
    return numbers;
  }


  // The members defined in this file (the others are instantiated where
  // they are defined).
  template class MembraneProblem<2>;
} // namespace StepMembranes
