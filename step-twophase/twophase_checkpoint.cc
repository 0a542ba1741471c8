// Checkpoint and resume of step-twophase. The format (a text file, see
// doc/step-twophase.md) holds everything the time loop needs to continue
// exactly as an uninterrupted run: the problem it belongs to, time, dt,
// step number, output bookkeeping, the state of every cell, and the history
// of the steps (so that the tables of a resumed run are complete).

#include <vi/checkpoint.h>
#include <vi/errors.h>

#include "twophase_problem.h"

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <limits>
#include <sstream>

namespace StepTwoPhase
{
  namespace
  {
    using VI::Checkpoint::read_entry;

    const std::string checkpoint_name = "checkpoint.txt";
    const std::string checkpoint_head = "step-twophase checkpoint, format 1";
    const std::string wrong_head =
      "it does not start with <" + checkpoint_head + ">";

    void
    write_estimators(std::ostream &out, const EstimatorValues &eta)
    {
      out << ' ' << eta.disc << ' ' << eta.lin << ' ' << eta.alg << ' '
          << eta.flux << ' ' << eta.nonconformity << ' ' << eta.equilibrium
          << ' ' << eta.phase_transition;
    }

    void
    read_estimators(std::istream &in, EstimatorValues &eta)
    {
      in >> eta.disc >> eta.lin >> eta.alg >> eta.flux >> eta.nonconformity >>
        eta.equilibrium >> eta.phase_transition;
    }
  } // namespace


  // The parameters that define the problem: a checkpoint continues only
  // the problem it was written for. Solvers, time step, final time and
  // output may change on resume.
  std::vector<std::string>
  TwoPhaseProblem::problem_fingerprint() const
  {
    return VI::Checkpoint::problem_fingerprint(
      prm, {"Physics", "Boundary conditions", "Mesh"});
  }


  // The state of the time loop, written atomically (vi/checkpoint.h).
  void
  TwoPhaseProblem::write_checkpoint() const
  {
    TimerOutput::Scope t(timer, "checkpoint");
    VI::Checkpoint::write_atomically(
      parameters.output.directory + "/" + checkpoint_name,
      [&](std::ostream &out) {
        VI::Checkpoint::write_head(out, checkpoint_head, problem_fingerprint());
        out << "time " << time << '\n'
            << "time_step " << time_step << '\n'
            << "step " << step << '\n'
            << "next_output " << next_output << '\n';
        out << "cells " << scheme->n_cells() << '\n';
        for (unsigned int K = 0; K < scheme->n_cells(); ++K)
          {
            const CellState U = scheme->state(solution, K);
            out << U.S << ' ' << U.P << ' ' << U.chi << '\n';
          }
        out << "vtu_files " << vtu_files.size() << '\n';
        for (const auto &[t, name] : vtu_files)
          out << t << ' ' << name << '\n';
        out << "cuts " << cuts.size() << '\n';
        for (const TimeStepCut &c : cuts)
          out << c.time << ' ' << c.dt << ' ' << c.reason << '\n';
        out << "records " << records.size() << '\n';
        for (const StepRecord &r : records)
          {
            out << r.step << ' ' << r.time << ' ' << r.dt << ' ' << r.newton
                << ' ' << r.linear << ' ' << r.cuts << ' ' << r.rejected_newton
                << ' ' << r.rejected_linear << ' ' << r.gas_saturation_x0 << ' '
                << r.liquid_pressure_x0 << ' ' << r.gas_pressure_x0 << ' '
                << r.molar_fraction_x0 << ' ' << r.gas_front << ' '
                << r.wall_seconds;
            write_estimators(out, r.eta);
            out << ' ' << r.iterations.size() << '\n';
            for (const IterationRecord &it : r.iterations)
              {
                out << it.k << ' ' << it.i << ' ' << it.residual.equations
                    << ' ' << it.residual.complementarity << ' '
                    << it.step_length;
                write_estimators(out, it.eta);
                out << '\n';
              }
          }
      });
  }


  // Read the checkpoint of a previous run of the same problem; any problem
  // with the file is bad input (exit status 1) before anything is written.
  void
  TwoPhaseProblem::read_checkpoint()
  {
    const std::string file =
      parameters.output.directory + "/" + checkpoint_name;
    std::ifstream in(file);
    if (!in)
      throw VI::InputError("Time stepping/Resume = true, but there is no "
                           "checkpoint " +
                           file);
    try
      {
        if (const auto d = VI::Checkpoint::read_head(
              in, checkpoint_head, wrong_head, problem_fingerprint(), "-"))
          throw VI::InputError("Time stepping/Resume: " + file +
                               " was written for another problem (" + d->first +
                               " there, " + d->second + " here)");
        read_entry(in, "time", time);
        read_entry(in, "time_step", time_step);
        read_entry(in, "step", step);
        read_entry(in, "next_output", next_output);
        unsigned int n_cells = 0;
        read_entry(in, "cells", n_cells);
        if (n_cells != scheme->n_cells())
          throw std::runtime_error("wrong number of cells");
        for (unsigned int K = 0; K < n_cells; ++K)
          {
            CellState U;
            in >> U.S >> U.P >> U.chi;
            scheme->set_state(K, U, solution);
          }

        std::size_t n = 0;
        read_entry(in, "vtu_files", n);
        vtu_files.resize(n);
        for (auto &[t, name] : vtu_files)
          in >> t >> name;

        read_entry(in, "cuts", n);
        cuts.resize(n);
        for (TimeStepCut &c : cuts)
          {
            in >> c.time >> c.dt;
            std::getline(in, c.reason);
            if (!c.reason.empty() && c.reason[0] == ' ')
              c.reason.erase(0, 1);
          }

        read_entry(in, "records", n);
        records.resize(n);
        for (StepRecord &r : records)
          {
            std::size_t n_iterations = 0;
            in >> r.step >> r.time >> r.dt >> r.newton >> r.linear >> r.cuts >>
              r.rejected_newton >> r.rejected_linear >> r.gas_saturation_x0 >>
              r.liquid_pressure_x0 >> r.gas_pressure_x0 >>
              r.molar_fraction_x0 >> r.gas_front >> r.wall_seconds;
            read_estimators(in, r.eta);
            in >> n_iterations;
            r.iterations.resize(n_iterations);
            for (IterationRecord &it : r.iterations)
              {
                in >> it.k >> it.i >> it.residual.equations >>
                  it.residual.complementarity >> it.step_length;
                read_estimators(in, it.eta);
              }
          }
        VI::Checkpoint::read_end(in, "it is truncated");
      }
    catch (const std::runtime_error &e)
      {
        if (dynamic_cast<const VI::InputError *>(&e))
          throw;
        throw VI::InputError("Time stepping/Resume: " + file +
                             " is not a valid checkpoint (" + e.what() + ")");
      }
    // The outputs due up to the checkpoint's time were written before it
    // (this run may have been given other output times).
    next_output = std::upper_bound(parameters.time.output_times.begin(),
                                   parameters.time.output_times.end(),
                                   time) -
                  parameters.time.output_times.begin();
  }
} // namespace StepTwoPhase
