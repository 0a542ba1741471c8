// step-parabolic: the problem, its data checks and mesh, the choice of the
// time steps and the loop over them (run()).

#include "parabolic_problem.h"

#include <deal.II/base/quadrature_lib.h>
#include <deal.II/base/utilities.h>
#include <deal.II/fe/fe_values.h>
#include <deal.II/fe/mapping_q.h>

#include <vi/errors.h>
#include <vi/memory_budget.h>
#include <vi/nodal_fields.h>
#include <vi/program.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <iomanip>
#include <sstream>

namespace StepParabolic
{
  // The bound and its components up to the current time t (see
  // StepEstimate and doc/step-parabolic.md): with the cone correction
  // d = s~ - u_h and N = (sum_n int_In |||d|||^2 + |d(t)|^2)^(1/2),
  //   |||u - u_ht|||_(0,t) + |(u - u_h)(t)| <= eta = the smaller of
  //     (eta_init^2 + sum_n eta_n^2)^(1/2) + N,                 (d_t d in H^-1)
  //     G + (eta_init^2 + sum_n eta_l2,n^2)^(1/2) + N,          (d_t d in L2)
  //     the same with membrane alpha's load, and perhaps the multiplier's
  //     non-conforming part, in L2 too (four variants),
  // with G = sum_n |d^n - d^(n-1)| (plus what the variants add).
  // Each of the first two is split by the triangle inequality; the smaller
  // split bounds eta.
  template <int dim>
  double
  ParabolicProblem<dim>::Accumulated::h_minus_1_bound() const
  {
    return std::sqrt(eta_init * eta_init + eta_squared);
  }


  template <int dim>
  double
  ParabolicProblem<dim>::Accumulated::l2_bound() const
  {
    return change + std::sqrt(eta_init * eta_init + l2_squared);
  }


  template <int dim>
  double
  ParabolicProblem<dim>::Accumulated::variant_bound(const unsigned int v) const
  {
    return change + variant_l2[v] +
           std::sqrt(eta_init * eta_init + variant_squared[v]);
  }


  template <int dim>
  bool
  ParabolicProblem<dim>::Accumulated::l2_bound_is_smaller() const
  {
    return l2_bound() < h_minus_1_bound();
  }


  template <int dim>
  unsigned int
  ParabolicProblem<dim>::Accumulated::smallest_variant() const
  {
    double       smallest = std::min(l2_bound(), h_minus_1_bound());
    unsigned int which    = 0;
    // (over an obstacle there are none: their sums stay zero)
    for (unsigned int v = 0; v < variant_squared.size(); ++v)
      if (variant_squared[v] > 0 && variant_bound(v) < smallest)
        {
          smallest = variant_bound(v);
          which    = v + 1;
        }
    return which;
  }


  template <int dim>
  double
  ParabolicProblem<dim>::Accumulated::eta() const
  {
    const double       N = std::sqrt(nonc_squared + final_nonc * final_nonc);
    const unsigned int v = smallest_variant();
    return (v > 0 ? variant_bound(v - 1) :
                    std::min(l2_bound(), h_minus_1_bound())) +
           N;
  }


  template <int dim>
  double
  ParabolicProblem<dim>::Accumulated::eta_disc() const
  {
    const double N =
      std::sqrt(nonc_squared_disc + final_nonc_disc * final_nonc_disc);
    if (l2_bound_is_smaller())
      return change_disc + std::sqrt(l2_disc_squared) + N;
    return std::sqrt(disc_squared) + N;
  }


  template <int dim>
  double
  ParabolicProblem<dim>::Accumulated::eta_lin() const
  {
    const double N =
      std::sqrt(nonc_squared_lin + final_nonc_lin * final_nonc_lin);
    if (l2_bound_is_smaller())
      return change_lin + std::sqrt(l2_lin_squared) + N;
    return std::sqrt(lin_squared) + N;
  }


  template <int dim>
  double
  ParabolicProblem<dim>::Accumulated::eta_alg() const
  {
    return std::sqrt(alg_squared);
  }


  template <int dim>
  double
  ParabolicProblem<dim>::Accumulated::error() const
  {
    return std::sqrt(error_squared + final_error * final_error);
  }


  template <int dim>
  ParabolicProblem<dim>::ParabolicProblem(const Parameters &parameters,
                                          ParameterHandler &prm,
                                          const MPI_Comm    comm)
      : Discretisation(VI::Domain(parameters.mesh, parameters.problem.boundary),
                       parameters.discretization.degree,
                       parameters.estimators.flux_degree_for(
                         parameters.discretization.degree),
                       comm)
      , parameters(parameters)
      , prm(prm)
      , pcout(std::cout, Utilities::MPI::this_mpi_process(comm) == 0)
      , timer(pcout, TimerOutput::never, TimerOutput::wall_times)
      , center(domain.template center<dim>())
      , data(make_parabolic_data<dim>(parameters.problem, center))
      , C(VI::ComplementarityFunction(parameters.nonlinear_solver.c_function))
      , friedrichs_constant(domain.friedrichs_constant())
      , contact_system(C, parameters, timer)
      , multiplier_function(make_multiplier_function(contact_system))
      , stopping(parameters.nonlinear_solver,
                 stopping_hooks(),
                 parameters.output.verbose ? &pcout : nullptr)
      , run_record("step-parabolic", parameters.output.directory, timer, comm)
  {
    run_record.complete_summary = [this](VI::Json &summary) {
      add_totals(summary);
    };
  }


  // The data must be finite and admit a solution: g1 >= g2 on the boundary
  // (at t = 0 and at the final time) and an initial state in the cone,
  // u1_0 >= u2_0, checked at the quadrature points and the nodes of the
  // first mesh before anything is written.
  template <int dim>
  void
  ParabolicProblem<dim>::check_data() const
  {
    std::string violation;
    const auto  report = [&](const std::string &message) {
      if (violation.empty())
        violation = message;
    };
    const auto below = [](const double a, const double b) {
      return a - b < -1e-12 * std::max({1., std::abs(a), std::abs(b)});
    };

    std::vector<Point<dim>> unit_points = quadrature.get_points();
    for (const auto &p : fe.get_unit_support_points())
      unit_points.push_back(p);

    for (const double t : {0., parameters.time.final_time})
      {
        data.set_time(t);
        for (const auto &cell : triangulation.active_cell_iterators())
          if (cell->is_locally_owned() && violation.empty())
            {
              for (const auto &unit_point : unit_points)
                {
                  const Point<dim> p =
                    mapping->transform_unit_to_real_cell(cell, unit_point);
                  std::ostringstream message;
                  const double f1 = data.f1->value(p), f2 = data.f2->value(p);
                  const double a = data.initial_u1->value(p),
                               b = data.initial_u2->value(p);
                  const double psi =
                    data.obstacle ? data.obstacle->value(p) : 0.;
                  if (!std::isfinite(f1) || !std::isfinite(f2))
                    message << "the forces are not finite at (" << p
                            << "), t = " << t << ": f1 = " << f1
                            << ", f2 = " << f2;
                  else if (!std::isfinite(psi))
                    message << "the obstacle is not finite at (" << p
                            << "), t = " << t << ": obstacle = " << psi;
                  else if (!std::isfinite(a) || !std::isfinite(b))
                    message << "the initial data are not finite at (" << p
                            << "): u1_0 = " << a << ", u2_0 = " << b;
                  else if (below(a, b) && data.obstacle)
                    message << "u1_0 is below the obstacle at (" << p
                            << "): u1_0 = " << a << ", obstacle = " << b
                            << "; the initial state must lie above it";
                  else if (below(a, b))
                    message << "u1_0 < u2_0 at (" << p << "): u1_0 = " << a
                            << ", u2_0 = " << b
                            << "; the initial state must satisfy u1 >= u2";
                  if (!message.str().empty())
                    report(message.str());
                }
              for (const unsigned int f : cell->face_indices())
                if (cell->face(f)->at_boundary() &&
                    domain.is_clamped(cell->face(f)->boundary_id()))
                  for (const auto &unit_point : fe.get_unit_support_points())
                    {
                      // Face 2d + s of the unit cell is {x_d = s}.
                      if (std::abs(unit_point[f / 2] - double(f % 2)) > 1e-12)
                        continue;
                      const Point<dim> p =
                        mapping->transform_unit_to_real_cell(cell, unit_point);
                      const double g1 = data.g1->value(p),
                                   g2 = data.g2->value(p);
                      std::ostringstream message;
                      if (!std::isfinite(g1) || !std::isfinite(g2))
                        message << "the boundary data are not finite at (" << p
                                << "), t = " << t << ": g1 = " << g1
                                << (data.obstacle ? ", obstacle = " : ", g2 = ")
                                << g2;
                      else if (below(g1, g2) && data.obstacle)
                        message << "g1 is below the obstacle on the boundary "
                                << "at (" << p << "), t = " << t
                                << ": g1 = " << g1 << ", obstacle = " << g2
                                << "; the constraint u1 >= obstacle cannot "
                                   "hold there";
                      else if (below(g1, g2))
                        message << "g1 < g2 on the boundary at (" << p
                                << "), t = " << t << ": g1 = " << g1
                                << ", g2 = " << g2
                                << "; the constraint u1 >= u2 cannot hold "
                                   "there";
                      if (!message.str().empty())
                        report(message.str());
                    }
            }
      }
    data.set_time(0.);
    for (const std::string &message :
         Utilities::MPI::all_gather(comm, violation))
      if (!message.empty())
        throw VI::InputError("Problem: " + message);
  }


  // Adaptive time steps: the temporal estimator eta_time^n + |eta_osc|_In
  // ((dt/3)^(1/2) |||u^n - u^(n-1)||| ~ dt^(3/2), and the change of the
  // forces, also ~ dt^(3/2)) over the spatial one eta_space^n (~ dt^(1/2))
  // grows like dt, so the step that meets the target ratio is
  // dt target / ratio; it is
  // taken with a safety factor 0.9, limited to a change by a factor in
  // [1/5, Growth factor] and to [Minimal, Maximal time step]. A step whose
  // ratio exceeds Rejection factor times the target is recomputed.
  template <int dim>
  void
  ParabolicProblem<dim>::choose_next_time_step(const StepEstimate &e,
                                               bool               &accept)
  {
    const auto &ts = parameters.time;
    accept         = true;
    if (!ts.adaptive)
      {
        next_time_step = ts.time_step;
        return;
      }
    const double target = ts.time_space_ratio;
    const double ratio =
      e.eta_space > 0 ? (e.eta_time + e.oscillation) / e.eta_space : 0.;
    const double factor =
      ratio > 0 ? std::clamp(0.9 * target / ratio, 0.2, ts.growth_factor) :
                  ts.growth_factor;
    next_time_step = std::clamp(time_step * factor,
                                ts.minimal_time_step,
                                ts.maximal_time_step);
    if (ratio > ts.rejection_factor * target &&
        time_step > ts.minimal_time_step * (1. + 1e-12))
      accept = false;
  }


  // The run: the set-up (or a checkpoint's state), then time steps until T
  // (or until this run's share of steps is done), each step solved by
  // semismooth Newton with its space-time estimate, and repeated with a
  // smaller dt while the estimate says that the temporal error dominates.
  template <int dim>
  void
  ParabolicProblem<dim>::run()
  {
    start_run();
    const auto  &ts            = parameters.time;
    const double end_tolerance = 1e-12 * ts.final_time;
    bool         stopped       = false;
    while (time < ts.final_time - end_tolerance)
      {
        if (ts.steps_per_run > 0 && steps_this_run == ts.steps_per_run)
          {
            stopped = true;
            break;
          }
        Timer step_timer;
        solve_until_accepted();
        accept_time_step();
        const double wall = step_timer.wall_time();
        record_step(wall);

        const bool at_end = time >= ts.final_time - end_tolerance;
        if (at_end ||
            (ts.output_interval > 0 && step % ts.output_interval == 0))
          output_results();
        if (ts.checkpoint_interval > 0 && step % ts.checkpoint_interval == 0 &&
            !at_end)
          write_checkpoint();
        print_step(wall);
      }
    finish_run(stopped);
  }


  template <int dim>
  std::string
  ParabolicProblem<dim>::description() const
  {
    const auto        &linear = parameters.linear_solver;
    const auto        &ts     = parameters.time;
    std::ostringstream line;
    line << "Test case " << data.name << " on the " << domain.name() << ", Q"
         << fe.degree << " elements, backward Euler with "
         << (ts.adaptive ? "adaptive dt from " : "dt = ") << ts.time_step
         << " to T = " << ts.final_time << ", Newton-" << C.name() << " ("
         << VI::to_string(parameters.nonlinear_solver.strategy) << "), "
         << (linear.solver == VI::LinearSolverType::direct ?
               "direct solver " + linear.direct_package :
               "GMRES + " + VI::to_string(linear.preconditioner))
         << (parameters.estimators.enabled ? ", estimators on" : "");
    return line.str();
  }


  // The state at t = 0 (or at the checkpoint of an earlier run), its data
  // checked before anything is written; then the header and the summary's
  // start (with the steps of the earlier run).
  template <int dim>
  void
  ParabolicProblem<dim>::start_run()
  {
    const auto &ts = parameters.time;
    // A mesh that cannot fit stops the run before anything is allocated.
    VI::MemoryBudget(parameters.mesh, parameters.discretization, comm).check();
    if (!parameters.compare_with.empty())
      {
        const std::string file  = parameters.compare_with + "/checkpoint.txt";
        bool              found = false;
        if (Utilities::MPI::this_mpi_process(comm) == 0)
          found = static_cast<bool>(std::ifstream(file));
        if (!Utilities::MPI::broadcast(comm, found, 0))
          throw VI::InputError("Output/Compare with: there is no checkpoint <" +
                               file + ">");
      }

    if (ts.resume)
      read_checkpoint();
    else
      {
        make_grid(parameters.mesh.initial_refinements);
        check_data();
      }
    run_record.start(prm, description(), "steps");
    if (ts.resume)
      {
        for (const std::string &text : step_json)
          run_record.add(VI::Json::raw(text));
        pcout << "Resuming at t = " << time << " (step " << step << ")"
              << std::endl;
      }
    else
      {
        setup_system();
        set_initial_values();
        next_time_step = ts.time_step;
        output_results();
      }
    run_record.summary["mesh"] =
      VI::Json::object({{"cells", triangulation.n_global_active_cells()},
                        {"dofs", n_fields * dof_handler.n_dofs()},
                        {"dofs_per_field", dof_handler.n_dofs()}});
    pcout << "Mesh: " << triangulation.n_global_active_cells() << " cells, "
          << n_fields * dof_handler.n_dofs() << " unknowns ("
          << dof_handler.n_dofs() << " per field)";
    if (parameters.estimators.enabled)
      pcout << "; eta_init = " << std::scientific << std::setprecision(3)
            << totals.eta_init << std::defaultfloat;
    pcout << std::endl;
  }


  // The step from t_(n-1) = time, solved again with the smaller dt that
  // choose_next_time_step() proposes until it accepts the step. A solver
  // failure writes the summary of the completed steps, marked as failed.
  template <int dim>
  void
  ParabolicProblem<dim>::solve_until_accepted()
  {
    const auto &ts     = parameters.time;
    rejected_this_step = newton_this_step = linear_this_step = 0;
    for (;;)
      {
        // The last step ends at T (and is not left shorter than 1% of dt).
        time_step = next_time_step;
        if (time + 1.01 * time_step >= ts.final_time)
          time_step = ts.final_time - time;
        try
          {
            run_record.guard([&] { solve_time_step(); });
          }
        catch (const VI::SolverFailure &)
          {
            pcout << "Step " << step + 1 << " (t = " << time + time_step
                  << ") failed." << std::endl;
            throw;
          }
        newton_this_step += newton_report.iterations;
        linear_this_step += newton_report.linear_iterations;
        totals.newton += newton_report.iterations;
        totals.linear += newton_report.linear_iterations;

        bool accept = true;
        choose_next_time_step(final_estimate ? *final_estimate : StepEstimate(),
                              accept);
        if (accept)
          return;
        ++rejected_this_step;
        ++totals.rejected;
        pcout << "   step to t = " << time + time_step << " rejected: "
              << "(eta_time + eta_osc) / eta_space = "
              << (final_estimate->eta_time + final_estimate->oscillation) /
                   final_estimate->eta_space
              << ", dt " << time_step << " -> " << next_time_step << std::endl;
      }
  }


  // Accept the step: errors on I_n, the totals, then u_h^n becomes the
  // previous solution.
  template <int dim>
  void
  ParabolicProblem<dim>::accept_time_step()
  {
    postprocess();
    if (data.has_exact_solution())
      compute_errors();
    time += time_step;
    ++step;
    ++steps_this_run;
    if (final_estimate)
      {
        const StepEstimate &e = *final_estimate;
        totals.eta_squared += e.eta * e.eta;
        totals.disc_squared += e.eta_disc * e.eta_disc;
        totals.lin_squared += e.eta_lin * e.eta_lin;
        totals.alg_squared += e.eta_alg * e.eta_alg;
        totals.l2_squared += e.eta_l2 * e.eta_l2;
        totals.l2_disc_squared += e.eta_l2_disc * e.eta_l2_disc;
        totals.l2_lin_squared += e.eta_l2_lin * e.eta_l2_lin;
        totals.change += e.change;
        totals.change_disc += e.change_disc;
        totals.change_lin += e.change_lin;
        for (unsigned int v = 0; v < e.eta_variant.size(); ++v)
          {
            totals.variant_squared[v] += e.eta_variant[v] * e.eta_variant[v];
            totals.variant_l2[v] += e.l2_variant[v];
          }
        totals.nonc_squared += e.nonc_squared;
        totals.nonc_squared_disc += e.nonc_squared_disc;
        totals.nonc_squared_lin += e.nonc_squared_lin;
        totals.final_nonc      = e.final_nonc;
        totals.final_nonc_disc = e.final_nonc_disc;
        totals.final_nonc_lin  = e.final_nonc_lin;
      }
    store_previous_step();
  }


  // The progress line of a step.
  template <int dim>
  void
  ParabolicProblem<dim>::print_step(const double wall) const
  {
    const StepRecord &r = records.back();
    pcout << "Step " << std::setw(4) << step << " t = " << std::setw(9)
          << std::left << time << std::right << " dt = " << std::setw(9)
          << std::left << time_step << std::right << ": Newton " << std::setw(2)
          << r.newton;
    if (parameters.linear_solver.solver == VI::LinearSolverType::gmres)
      pcout << " (" << std::setw(4) << r.linear << " GMRES)";
    pcout << ", contact " << std::setw(5) << r.contact;
    if (final_estimate)
      pcout << std::scientific << std::setprecision(2) << ", eta_n "
            << final_estimate->eta << " (disc " << final_estimate->eta_disc
            << ", lin " << final_estimate->eta_lin << ", alg "
            << final_estimate->eta_alg << ", time " << final_estimate->eta_time
            << ")" << std::defaultfloat;
    if (data.has_exact_solution())
      pcout << std::scientific << std::setprecision(3) << ", error " << r.error
            << std::defaultfloat;
    if (final_estimate && data.has_exact_solution())
      pcout << std::setprecision(3) << ", effectivity " << r.effectivity;
    if (r.rejected > 0)
      pcout << ", " << r.rejected << " rejected";
    pcout << std::setprecision(3) << ", " << wall << " s" << std::endl;
  }


  // The last checkpoint, the tables and the summary: "completed" at T,
  // "stopped" when this run's share of steps is done.
  template <int dim>
  void
  ParabolicProblem<dim>::finish_run(const bool stopped)
  {
    write_checkpoint();
    write_tables();
    if (!parameters.compare_with.empty() && !stopped)
      compare_with_run(parameters.compare_with);
    if (stopped)
      pcout << "\nStopped after " << steps_this_run
            << " steps (Time stepping/Steps per run) at t = " << time
            << "; continue with Time stepping/Resume = true." << std::endl;
    run_record.finish(
      "solution.pvd (ParaView), convergence.txt, summary.json, checkpoint",
      stopped ? "stopped" : "completed");
  }


  // The members defined in this file (the others are instantiated where
  // they are defined).
  template class ParabolicProblem<2>;
} // namespace StepParabolic
