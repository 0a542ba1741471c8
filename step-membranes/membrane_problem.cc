// step-membranes, conforming Q_p: the problem, its data checks and mesh, and
// the loop over the meshes (run()).

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
      : Discretisation(parameters.mesh, parameters.discretization, comm)
      , parameters(parameters)
      , prm(prm)
      , pcout(std::cout, Utilities::MPI::this_mpi_process(comm) == 0)
      // Wall times of rank 0: a TimerOutput without communicator needs no MPI
      // in its destructor, which also runs when a failure unwinds the stack.
      , timer(pcout, TimerOutput::never, TimerOutput::wall_times)
      , data(VI::make_membrane_data<dim>(parameters.problem,
                                         VI::geometry_center<dim>(geometry)))
      , C(VI::ComplementarityFunction(parameters.nonlinear_solver.c_function))
      , contact_system(C,
                       parameters.nonlinear_solver,
                       parameters.linear_solver,
                       timer)
      , multiplier_function(make_multiplier_function(contact_system))
      , stopping(parameters.nonlinear_solver,
                 stopping_hooks(),
                 parameters.output.verbose ? &pcout : nullptr)
      , run_record("step-membranes", parameters.output.directory, timer, comm)
  {
  }


  // The data must be finite and admit a solution: g1 >= g2 on the boundary
  // (otherwise the constraint u1 >= u2 contradicts the boundary condition).
  // Checked on the first mesh (forces at the quadrature points, boundary
  // data at the boundary support points) before anything is written.
  template <int dim>
  void
  MembraneProblem<dim>::check_data() const
  {
    VI::check_membrane_data(data,
                            triangulation,
                            *mapping,
                            quadrature.get_points(),
                            fe.get_unit_support_points(),
                            comm);
  }


  template <int dim>
  std::string
  MembraneProblem<dim>::description() const
  {
    std::ostringstream line;
    line << "Test case " << data.name << " on the " << parameters.mesh.geometry
         << ", Q" << fe.degree << " elements, " << solver_name() << " "
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
  void
  MembraneProblem<dim>::print_cycle_header(const unsigned int cycle) const
  {
    pcout << "Cycle " << cycle << ": " << triangulation.n_global_active_cells()
          << " cells, " << n_fields * dof_handler.n_dofs() << " unknowns ("
          << dof_handler.n_dofs() << " per field)" << std::endl;
  }


  template <int dim>
  VI::CycleNumbers
  MembraneProblem<dim>::cycle_numbers(const unsigned int cycle) const
  {
    VI::CycleNumbers numbers(cycle,
                             triangulation.n_global_active_cells(),
                             dof_handler.n_dofs(),
                             run_record.cycle_seconds());
    numbers.set_solve(solver_name(),
                      newton_report,
                      VI::counted_linear_solver(parameters.linear_solver),
                      n_contact_nodes);
    numbers.error_energy     = error_energy;
    numbers.error_multiplier = error_multiplier;
    if (final_estimate)
      numbers.estimate = final_estimate->eta;
    return numbers;
  }


  // On each mesh of the sequence: set up and assemble the contact system,
  // solve it by semismooth Newton from the previous mesh's solution (with
  // the adaptive stopping of the estimators), estimate, measure the error,
  // write, refine.
  template <int dim>
  void
  MembraneProblem<dim>::run()
  {
    run_record.start(prm, description());
    make_grid(parameters.mesh.initial_refinements);
    check_data();

    for (unsigned int cycle = 0; cycle < parameters.mesh.cycles; ++cycle)
      {
        run_record.start_cycle();
        if (cycle > 0)
          refine_mesh();
        solve_timer.restart();
        usage_at_solve_start = VI::ProcessUsage::now(comm);
        setup_system();
        assemble_system();
        initialize_iterate();
        print_cycle_header(cycle);

        const std::optional<Vector> initial_iterate =
          parameters.compare_with_petsc_vi ? std::optional<Vector>(solution) :
                                             std::nullopt;
        run_record.guard([&] { solve(); });
        solve_timer.stop();
        solve_usage = VI::ProcessUsage::now(comm) - usage_at_solve_start;

        postprocess();
        compute_errors();
        output_results(cycle);
        run_record.stop_cycle();
        pcout << VI::to_string(cycle_numbers(cycle)) << std::endl;

        petsc_vi_run.reset();
        if (initial_iterate)
          compare_with_petsc_vi(*initial_iterate);
        record_cycle(cycle);
      }

    write_tables();
    run_record.finish(
      "solution_*.pvtu (ParaView), convergence.txt, summary.json");
  }


  // Explicit instantiations of this file's members.
  template MembraneProblem<2>::MembraneProblem(const Parameters &parameters,
                                               ParameterHandler &prm,
                                               const MPI_Comm    comm);
  template void
  MembraneProblem<2>::check_data() const;
  template std::string
  MembraneProblem<2>::description() const;
  template std::string
  MembraneProblem<2>::solver_name() const;
  template void
  MembraneProblem<2>::print_cycle_header(const unsigned int cycle) const;
  template VI::CycleNumbers
  MembraneProblem<2>::cycle_numbers(const unsigned int cycle) const;
  template void
  MembraneProblem<2>::run();
} // namespace StepMembranes
