// Checkpoint and resume of step-parabolic. A checkpoint is the mesh with
// the solution attached (deal.II's p4est serialisation, so a run may resume
// on another number of ranks) and a text file with everything else the
// time loop needs to continue exactly as an uninterrupted run: the problem
// it belongs to, time, step and the next dt, the running sums of the
// estimators and errors, the rows of the table and the records of
// summary.json, and the list of VTU files.

#include <deal.II/distributed/solution_transfer.h>
#include <deal.II/dofs/dof_tools.h>
#include <deal.II/fe/fe_values.h>

#include <vi/checkpoint.h>
#include <vi/errors.h>
#include <vi/nodal_fields.h>
#include <vi/program.h>

#include "parabolic_problem.h"

#include <filesystem>
#include <fstream>
#include <iomanip>
#include <limits>
#include <sstream>

namespace StepParabolic
{
  namespace
  {
    using VI::Checkpoint::read_entry;

    const std::string checkpoint_name = "checkpoint.txt";
    const std::string checkpoint_head = "step-parabolic checkpoint, format 3";
    const std::string wrong_head      = "not a checkpoint of step-parabolic";

    /// The files Triangulation::save() writes for `name`.
    std::vector<std::string>
    mesh_files(const std::string &name)
    {
      return {name,
              name + "_fixed.data",
              name + "_variable.data",
              name + ".info"};
    }

    /// The text of `file`, read on rank 0 and broadcast to every rank;
    /// whether rank 0 could open it.
    std::pair<bool, std::string>
    read_on_rank_zero(const std::string &file, const MPI_Comm comm)
    {
      bool        found = false;
      std::string text;
      if (Utilities::MPI::this_mpi_process(comm) == 0)
        {
          std::ifstream in(file);
          found = static_cast<bool>(in);
          std::ostringstream content;
          if (in)
            content << in.rdbuf();
          text = content.str();
        }
      return {Utilities::MPI::broadcast(comm, found, 0),
              Utilities::MPI::broadcast(comm, text, 0)};
    }
  } // namespace


  // The parameters that define the problem (Problem, Mesh, Discretization)
  // as "Section/Name = value" lines: a checkpoint continues only the problem
  // it was written for. Solvers, time stepping and output may change.
  template <int dim>
  std::vector<std::string>
  ParabolicProblem<dim>::problem_fingerprint() const
  {
    return VI::Checkpoint::problem_fingerprint(
      prm, {"Problem", "Mesh", "Discretization"});
  }


  // The mesh and (u1h, u2h, X3) of the current step go to
  // checkpoint-NNNNNN.mesh*, the rest to checkpoint.txt, written to a
  // temporary file and renamed: checkpoint.txt always names a complete
  // mesh file, and the previous one is removed only afterwards. Doubles are
  // written with 17 significant digits, which read back to the same bits.
  template <int dim>
  void
  ParabolicProblem<dim>::write_checkpoint()
  {
    TimerOutput::Scope t(timer, "checkpoint");
    const std::string &directory = parameters.output.directory;
    std::ostringstream mesh_name;
    mesh_name << "checkpoint-" << std::setw(6) << std::setfill('0') << step
              << ".mesh";

    Vector X3(owned_nodes, comm), X3_ghosted(owned_nodes, relevant_nodes, comm);
    VI::NodalFields::extract(solution, VI::NodalFields::multiplier, X3);
    X3_ghosted = X3;
    {
      parallel::distributed::SolutionTransfer<dim, Vector> transfer(
        dof_handler);
      transfer.prepare_for_serialization(
        std::vector<const Vector *>{&u1_h, &u2_h, &X3_ghosted});
      triangulation.save(directory + "/" + mesh_name.str());
    }

    if (Utilities::MPI::this_mpi_process(comm) == 0)
      {
        VI::Checkpoint::write_atomically(
          directory + "/" + checkpoint_name, [&](std::ostream &out) {
            VI::Checkpoint::write_head(out,
                                       checkpoint_head,
                                       problem_fingerprint());
            out << "time " << time << '\n'
                << "time_step " << time_step << '\n'
                << "next_time_step " << next_time_step << '\n'
                << "step " << step << '\n'
                << "mesh " << mesh_name.str() << '\n';
            const Accumulated &a = totals;
            out << "totals " << a.eta_init << ' ' << a.eta_squared << ' '
                << a.disc_squared << ' ' << a.lin_squared << ' '
                << a.alg_squared << ' ' << a.nonc_squared << ' '
                << a.nonc_squared_disc << ' ' << a.nonc_squared_lin << ' '
                << a.final_nonc << ' ' << a.final_nonc_disc << ' '
                << a.final_nonc_lin << ' ' << a.error_squared << ' '
                << a.final_error << ' ' << a.newton << ' ' << a.linear << ' '
                << a.rejected << '\n';
            out << "l2_totals " << a.l2_squared << ' ' << a.l2_disc_squared
                << ' ' << a.l2_lin_squared << ' ' << a.change << ' '
                << a.change_disc << ' ' << a.change_lin << '\n';
            const auto learnt = stopping.learnt_prediction();
            out << "gmres_prediction " << learnt.alg_per_residual << ' '
                << learnt.alg_threshold << ' ' << learnt.unknowns << '\n';
            out << "variant_totals";
            for (unsigned int v = 0; v < a.variant_squared.size(); ++v)
              out << ' ' << a.variant_squared[v] << ' ' << a.variant_l2[v];
            out << '\n';
            out << "records " << records.size() << '\n';
            for (const StepRecord &r : records)
              out << r.step << ' ' << r.time << ' ' << r.dt << ' ' << r.newton
                  << ' ' << r.linear << ' ' << r.rejected << ' ' << r.contact
                  << ' ' << r.eta_step << ' ' << r.eta_time << ' ' << r.eta
                  << ' ' << r.error << ' ' << r.effectivity << '\n';
            out << "summary_steps " << step_json.size() << '\n';
            for (const std::string &text : step_json)
              out << text.size() << '\n' << text << '\n';
            out << "vtu_files " << vtu_files.size() << '\n';
            for (const auto &[t, name] : vtu_files)
              out << t << ' ' << name << '\n';
          });
        if (!checkpoint_mesh.empty() && checkpoint_mesh != mesh_name.str())
          for (const std::string &old : mesh_files(checkpoint_mesh))
            std::filesystem::remove(directory + "/" + old);
      }
    checkpoint_mesh = mesh_name.str();
  }


  // Read checkpoint.txt (on rank 0, then on every rank from a broadcast
  // copy), check that it belongs to this problem, load the mesh with the
  // solution attached, and set up the state of the time loop.
  template <int dim>
  void
  ParabolicProblem<dim>::read_checkpoint()
  {
    const std::string &directory = parameters.output.directory;
    const std::string  file      = directory + "/" + checkpoint_name;
    const auto [found, text]     = read_on_rank_zero(file, comm);
    if (!found)
      throw VI::InputError("Time stepping/Resume = true, but there is no "
                           "checkpoint <" +
                           file + ">");

    std::istringstream in(text);
    try
      {
        if (const auto d = VI::Checkpoint::read_head(
              in, checkpoint_head, wrong_head, problem_fingerprint(), "(none)"))
          throw VI::InputError("the checkpoint <" + file +
                               "> belongs to another problem: " + d->second +
                               " here, " + d->first + " there");
        read_entry(in, "time", time);
        read_entry(in, "time_step", time_step);
        read_entry(in, "next_time_step", next_time_step);
        read_entry(in, "step", step);
        read_entry(in, "mesh", checkpoint_mesh);
        Accumulated &a = totals;
        read_entry(in, "totals", a.eta_init);
        in >> a.eta_squared >> a.disc_squared >> a.lin_squared >>
          a.alg_squared >> a.nonc_squared >> a.nonc_squared_disc >>
          a.nonc_squared_lin >> a.final_nonc >> a.final_nonc_disc >>
          a.final_nonc_lin >> a.error_squared >> a.final_error >> a.newton >>
          a.linear >> a.rejected;
        read_entry(in, "l2_totals", a.l2_squared);
        in >> a.l2_disc_squared >> a.l2_lin_squared >> a.change >>
          a.change_disc >> a.change_lin;
        // (GMRES's first check of the next step is predicted as it would
        // have been without the interruption)
        typename decltype(stopping)::Prediction learnt;
        read_entry(in, "gmres_prediction", learnt.alg_per_residual);
        in >> learnt.alg_threshold >> learnt.unknowns;
        stopping.restore_prediction(learnt);
        read_entry(in, "variant_totals", a.variant_squared[0]);
        in >> a.variant_l2[0];
        for (unsigned int v = 1; v < a.variant_squared.size(); ++v)
          in >> a.variant_squared[v] >> a.variant_l2[v];
        std::size_t n = 0;
        read_entry(in, "records", n);
        records.resize(n);
        for (StepRecord &r : records)
          in >> r.step >> r.time >> r.dt >> r.newton >> r.linear >>
            r.rejected >> r.contact >> r.eta_step >> r.eta_time >> r.eta >>
            r.error >> r.effectivity;
        read_entry(in, "summary_steps", n);
        step_json.resize(n);
        for (std::string &json : step_json)
          {
            std::size_t length = 0;
            in >> length;
            in.get(); // the newline
            json.resize(length);
            in.read(json.data(), length);
          }
        read_entry(in, "vtu_files", n);
        vtu_files.resize(n);
        for (auto &[t, name] : vtu_files)
          in >> t >> name;
        VI::Checkpoint::read_end(in, "expected <end>");
      }
    catch (const std::runtime_error &error)
      {
        if (dynamic_cast<const VI::InputError *>(&error))
          throw;
        throw VI::InputError("cannot read the checkpoint <" + file +
                             ">: " + error.what());
      }

    const std::string mesh = directory + "/" + checkpoint_mesh;
    if (!std::filesystem::exists(mesh))
      throw VI::InputError("the checkpoint <" + file + "> names the mesh <" +
                           mesh + ">, which does not exist");
    domain.make_coarse_mesh(triangulation);
    triangulation.load(mesh);
    mapping->initialize(*geometry_mapping, triangulation);
    check_data();

    data.set_time(time);
    setup_system();
    Vector u1(owned_nodes, comm), u2(owned_nodes, comm), X3(owned_nodes, comm);
    {
      parallel::distributed::SolutionTransfer<dim, Vector> transfer(
        dof_handler);
      std::vector<Vector *> fields = {&u1, &u2, &X3};
      transfer.deserialize(fields);
    }
    solution = 0;
    VI::NodalFields::insert_displacements(u1, u2, solution);
    VI::NodalFields::insert(X3, VI::NodalFields::multiplier, solution);
    store_previous_step();
    // With fixed steps, the time step of this run's parameters.
    if (!parameters.time.adaptive)
      next_time_step = parameters.time.time_step;
    // The coupling D, which postprocess() needs for lambda_h.
    time_step = next_time_step;
    assemble_system();
    postprocess();
  }


  // The difference between the final solution of this run and that of
  // another run of the same problem, read from its checkpoint: with the
  // same forest and number of ranks the two meshes are the same, cell by
  // cell and partition by partition, so the local values of the two
  // solutions can be compared on every owned cell:
  //   |||u_h - u_h'|||, |u_h - u_h'| (both membranes).
  template <int dim>
  void
  ParabolicProblem<dim>::compare_with_run(const std::string &other_directory)
  {
    const std::string  file = other_directory + "/" + checkpoint_name;
    std::istringstream in(read_on_rank_zero(file, comm).second);
    double             other_time = 0;
    std::string        mesh_name;
    try
      {
        if (VI::Checkpoint::read_head(
              in, checkpoint_head, wrong_head, problem_fingerprint(), ""))
          throw std::runtime_error("it belongs to another problem");
        read_entry(in, "time", other_time);
        double       dummy;
        unsigned int other_step;
        read_entry(in, "time_step", dummy);
        read_entry(in, "next_time_step", dummy);
        read_entry(in, "step", other_step);
        read_entry(in, "mesh", mesh_name);
      }
    catch (const std::runtime_error &error)
      {
        throw VI::InputError(
          "Output/Compare with: cannot use the checkpoint <" + file +
          ">: " + error.what());
      }
    if (std::abs(other_time - time) > 1e-12 * parameters.time.final_time)
      {
        std::ostringstream message;
        message << "Output/Compare with: the checkpoint <" << file
                << "> is at t = " << other_time
                << ", this run ends at t = " << time;
        throw VI::InputError(message.str());
      }

    parallel::distributed::Triangulation<dim> other_mesh(comm);
    domain.make_coarse_mesh(other_mesh);
    other_mesh.load(other_directory + "/" + mesh_name);
    DoFHandler<dim> other_dofs(other_mesh);
    other_dofs.distribute_dofs(fe);
    const IndexSet other_owned = other_dofs.locally_owned_dofs();
    IndexSet       other_relevant;
    DoFTools::extract_locally_relevant_dofs(other_dofs, other_relevant);
    Vector o1(other_owned, comm), o2(other_owned, comm), o3(other_owned, comm);
    {
      parallel::distributed::SolutionTransfer<dim, Vector> transfer(other_dofs);
      std::vector<Vector *> fields = {&o1, &o2, &o3};
      transfer.deserialize(fields);
    }
    Vector other[2];
    for (unsigned int a = 0; a < 2; ++a)
      {
        other[a].reinit(other_owned, other_relevant, comm);
        other[a] = (a == 0 ? o1 : o2);
      }

    const QGauss<dim>      error_quadrature(fe.degree + 2);
    FEValues<dim>          values(*mapping,
                         fe,
                         error_quadrature,
                         update_values | update_gradients | update_JxW_values);
    const unsigned int     n_dofs = fe.n_dofs_per_cell();
    dealii::Vector<double> mine(n_dofs), theirs(n_dofs);
    const Vector          *own[2]    = {&u1_h, &u2_h};
    const double           mu[2]     = {data.mu1, data.mu2};
    double                 sums[2]   = {0., 0.}; // energy^2, L2^2
    bool                   same_mesh = other_mesh.n_global_active_cells() ==
                     triangulation.n_global_active_cells();
    auto their_cell = other_dofs.begin_active();
    for (const auto &cell : dof_handler.active_cell_iterators())
      {
        if (!same_mesh || their_cell == other_dofs.end())
          {
            same_mesh = false;
            break;
          }
        if (cell->is_locally_owned())
          {
            if (!their_cell->is_locally_owned() ||
                cell->id() != their_cell->id())
              {
                same_mesh = false;
                break;
              }
            values.reinit(cell);
            for (unsigned int a = 0; a < 2; ++a)
              {
                cell->get_dof_values(*own[a], mine);
                their_cell->get_dof_values(other[a], theirs);
                mine -= theirs;
                for (const unsigned int q : values.quadrature_point_indices())
                  {
                    double         value = 0;
                    Tensor<1, dim> gradient;
                    for (unsigned int i = 0; i < n_dofs; ++i)
                      {
                        value += mine(i) * values.shape_value(i, q);
                        gradient += mine(i) * values.shape_grad(i, q);
                      }
                    sums[0] += mu[a] * gradient.norm_square() * values.JxW(q);
                    sums[1] += value * value * values.JxW(q);
                  }
              }
          }
        ++their_cell;
      }
    if (Utilities::MPI::min(same_mesh ? 1u : 0u, comm) == 0)
      throw VI::InputError("Output/Compare with: the mesh of <" + file +
                           "> is not this run's mesh on these ranks (compare "
                           "runs on the same number of ranks)");
    double total[2];
    Utilities::MPI::sum(ArrayView<const double>(sums, 2),
                        comm,
                        ArrayView<double>(total, 2));
    const double energy = std::sqrt(total[0]), l2 = std::sqrt(total[1]);
    pcout << std::scientific << std::setprecision(3)
          << "Difference to the final solution of " << other_directory << ": "
          << energy << " (energy norm), " << l2 << " (L2 norm)"
          << std::defaultfloat << std::endl;
    run_record.summary["compared_with"] =
      VI::Json::object({{"directory", other_directory},
                        {"time", time},
                        {"difference_energy", energy},
                        {"difference_l2", l2}});
  }


  template void
  ParabolicProblem<2>::compare_with_run(const std::string &);
  template std::vector<std::string>
  ParabolicProblem<2>::problem_fingerprint() const;
  template void
  ParabolicProblem<2>::write_checkpoint();
  template void
  ParabolicProblem<2>::read_checkpoint();
} // namespace StepParabolic
