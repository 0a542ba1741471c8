#pragma once

#include <deal.II/base/mpi.h>
#include <deal.II/base/parameter_handler.h>
#include <deal.II/base/timer.h>
#include <deal.II/dofs/dof_handler.h>
#include <deal.II/fe/fe_q.h>
#include <deal.II/grid/tria.h>
#include <deal.II/lac/sparse_direct.h>
#include <deal.II/lac/sparse_ilu.h>
#include <deal.II/lac/sparse_matrix.h>
#include <deal.II/lac/sparsity_pattern.h>
#include <deal.II/lac/vector.h>

#include <vi/complementarity.h>
#include <vi/run_record.h>
#include <vi/semismooth_newton.h>
#include <vi/summary.h>

#include "finite_volume_scheme.h"
#include "twophase_estimators.h"
#include "twophase_parameters.h"

#include <memory>
#include <string>
#include <vector>

namespace StepTwoPhase
{
  using namespace dealii;

  /// A time in seconds in years, the unit of the output.
  inline double
  years(const double seconds)
  {
    return seconds / seconds_per_year;
  }

  /// One Newton iteration of a time step (what summary.json records).
  struct IterationRecord
  {
    unsigned int      k = 0, i = 0; ///< Newton step, linear iterations
    VI::ResidualNorms residual;
    double            step_length = 1.;
    EstimatorValues   eta; ///< only with the adaptive strategy
  };


  /// One accepted time step.
  struct StepRecord
  {
    unsigned int step = 0;
    double       time = 0., dt = 0.;     ///< seconds
    unsigned int newton = 0, linear = 0; ///< of the accepted attempt
    unsigned int cuts            = 0;    ///< failed attempts before it
    unsigned int rejected_newton = 0, rejected_linear = 0; ///< their work
    double       gas_saturation_x0 = 0., liquid_pressure_x0 = 0.,
           gas_pressure_x0 = 0., molar_fraction_x0 = 0.;
    double                       gas_front = 0.; ///< m
    EstimatorValues              eta;
    double                       wall_seconds = 0.;
    std::vector<IterationRecord> iterations;
  };


  /// A failed attempt, retried with a shorter step.
  struct TimeStepCut
  {
    double      time = 0., dt = 0.; ///< start and length of the attempt, s
    std::string reason;
  };


  /**
   * Water-hydrogen flow with gas appearance and disappearance in 1D
   * ([BJ14, BDMV20]): backward Euler and cell-centred finite volumes
   * (finite_volume_scheme.h), each time step solved by semismooth Newton
   * (min or Fischer-Burmeister) with GMRES and ILU(0), or by SUNDIALS KINSOL;
   * a posteriori estimators (twophase_estimators.h) that stop GMRES and
   * Newton adaptively; failed steps retried with shorter ones; checkpoints.
   * Serial: p4est has no 1D meshes, and 1000 cells take a second.
   */
  class TwoPhaseProblem
  {
  public:
    TwoPhaseProblem(const Parameters &parameters,
                    ParameterHandler &prm,
                    const MPI_Comm    comm);

    void
    run();

  private:
    void
    check_memory_budget() const;
    void
    make_grid();
    void
    setup_system();
    void
    set_initial_state();

    double
    next_stop() const;
    void
    advance_one_step();
    void
    solve_time_step(const double dt, StepRecord &record);
    void
    solve_with_semismooth_newton(StepRecord &record);
    void
    solve_with_kinsol(StepRecord &record);
    void
    prepare_linear_solver(const Vector<double> &X);
    double
    rounding_level(const Vector<double> &X) const;
    unsigned int
    solve_linear_system(const Vector<double> &rhs,
                        Vector<double>       &dX,
                        const double          relative_tolerance,
                        const bool            adaptive);
    void
    enforce_constraint_rows(const Vector<double> &rhs,
                            Vector<double>       &dX) const;
    bool
    is_admissible(const Vector<double> &X) const;
    void
    check_solution() const;

    void
    record_step(StepRecord &record);
    void
    output_results();
    void
    write_tables() const;
    /// The run's results in summary.json: the mesh, every step (from
    /// `records`), the time step cuts and the totals.
    void
    add_results(VI::Json &summary) const;
    /// The line that says what this run solves, and how; at the end, the
    /// totals and the benchmark's quantities at x = 0 on the screen.
    std::string
    description() const;
    void
    print_totals() const;
    void
    print_gas_at_x0() const;

    void
    write_checkpoint() const;
    void
    read_checkpoint();
    std::vector<std::string>
    problem_fingerprint() const;

    const Parameters    parameters;
    ParameterHandler   &prm;
    const MPI_Comm      comm;
    mutable TimerOutput timer;
    Timer               run_timer;

    const TwoPhaseModel         model;
    VI::ComplementarityFunction C;

    Triangulation<1>                    triangulation;
    std::vector<unsigned int>           cell_of; ///< K -> active cell index
    FE_Q<1>                             reconstruction_fe;
    DoFHandler<1>                       reconstruction_dof_handler;
    std::unique_ptr<FiniteVolumeScheme> scheme;
    std::unique_ptr<Estimators>         estimators;

    SparsityPattern      sparsity_pattern;
    SparseMatrix<double> jacobian;
    SparseILU<double>    ilu;
    bool                 ilu_initialized = false;
    SparseDirectUMFPACK  direct_solver;
    Vector<double>       linearization_point;
    /// rounding_level() at the last linearisation point
    double balance_rounding_level = 0.;

    Vector<double> solution;     ///< X^n (scaled unknowns)
    Vector<double> old_solution; ///< X^{n-1}

    double       time        = 0.;
    double       time_step   = 0.; ///< the step the next attempt starts from
    unsigned int step        = 0;
    unsigned int next_output = 0; ///< index into the output times
    std::vector<std::pair<double, std::string>> vtu_files;

    std::vector<StepRecord>  records;
    std::vector<TimeStepCut> cuts;

    /// Header, summary.json, failure guard, timing and closing line.
    VI::RunRecord run_record;
  };
} // namespace StepTwoPhase
