#include <deal.II/base/conditional_ostream.h>
#include <deal.II/base/mpi.h>
#include <deal.II/base/timer.h>
#include <deal.II/lac/dynamic_sparsity_pattern.h>
#include <deal.II/lac/sparsity_tools.h>
#include <deal.II/lac/trilinos_precondition.h>

#include <vi/complementarity.h>
#include <vi/contact_preconditioner.h>
#include <vi/contact_system.h>
#include <vi/errors.h>
#include <vi/nodal_fields.h>
#include <vi/parameters.h>

#include <cmath>
#include <iomanip>
#include <limits>

namespace VI
{
  using namespace dealii;
  using NodalFields::index;
  using NodalFields::n_fields;

  namespace
  {
    /// |b_E| / |b|: the share of the balance equations (the rows other than
    /// the constraint rows at `positions`) in b.
    double
    balance_fraction(const TrilinosWrappers::MPI::Vector &b,
                     const std::vector<std::size_t>      &positions)
    {
      const double *x               = b.begin();
      double        constraint_part = 0;
      for (const std::size_t k : positions)
        constraint_part += x[n_fields * k + 2] * x[n_fields * k + 2];
      constraint_part =
        Utilities::MPI::sum(constraint_part, b.get_mpi_communicator());
      const double whole = b.norm_sqr();
      return whole > 0 ? std::sqrt(std::max(0., 1. - constraint_part / whole)) :
                         1.;
    }
  } // namespace


  ContactSystem::ContactSystem(const ComplementarityFunction   &C,
                               const NonlinearSolverParameters &nonlinear,
                               const LinearSolverParameters    &linear,
                               TimerOutput                     &timer)
      : C(C)
      , nonlinear(nonlinear)
      , linear(linear)
      , timer(timer)
  {
  }


  ContactSystem::~ContactSystem() = default;


  void
  ContactSystem::reinit(const IndexSet                  &owned_nodes,
                        const AffineConstraints<double> &u1_constraints,
                        const MPI_Comm                   comm,
                        const IndexSet                  &condensed_nodes)
  {
    // Solvers and preconditioners hold on to the matrices of the old mesh.
    direct_solver.reset();
    ilu.reset();
    contact_preconditioner.reset();

    this->comm        = comm;
    this->owned_nodes = owned_nodes;
    rows.reinit(owned_nodes, u1_constraints);
    rhs.reinit(NodalFields::system_index_set(owned_nodes), comm);
    coupling_vector.reinit(owned_nodes, comm);
    condensed_positions.clear();
    for (const types::global_dof_index i : condensed_nodes)
      if (owned_nodes.is_element(i))
        condensed_positions.push_back(owned_nodes.index_within_set(i));
  }


  void
  ContactSystem::reinit_matrix(DynamicSparsityPattern &node_pattern,
                               const IndexSet         &relevant_nodes)
  {
    SparsityTools::distribute_sparsity_pattern(node_pattern,
                                               owned_nodes,
                                               comm,
                                               relevant_nodes);
    const IndexSet owned_system = NodalFields::system_index_set(owned_nodes);
    DynamicSparsityPattern system_pattern(
      NodalFields::system_index_set(relevant_nodes));
    NodalFields::make_system_sparsity(node_pattern,
                                      owned_nodes,
                                      system_pattern);
    matrix.reinit(owned_system, owned_system, system_pattern, comm);
  }


  void
  ContactSystem::set_coupling(
    const std::function<double(types::global_dof_index)> &coupling_of,
    const std::vector<types::global_dof_index>           &constrained_nodes,
    const bool                                            fixed_second_field)
  {
    using NodalFields::multiplier;
    coupling_vector = 0;
    for (const types::global_dof_index i : rows.nodes())
      {
        const double D     = coupling_of(i);
        coupling_vector(i) = D;
        matrix.set(index(i, NodalFields::u1), index(i, multiplier), -D);
        if (!fixed_second_field)
          matrix.set(index(i, NodalFields::u2), index(i, multiplier), +D);
      }
    for (const types::global_dof_index i : constrained_nodes)
      matrix.set(index(i, multiplier), index(i, multiplier), 1.);
    matrix.compress(VectorOperation::insert);
    coupling_vector.compress(VectorOperation::insert);
    multiplier_weight.assign(coupling_vector.begin(),
                             coupling_vector.begin() +
                               owned_nodes.n_elements());

    // Scales of the dimensionless residuals: |F| over the rows of the
    // contact nodes, and the multiplier coefficient |F|_inf / max D that
    // would balance the load.
    double local[2] = {0., 0.};
    for (const types::global_dof_index i : rows.nodes())
      for (const unsigned int field : {NodalFields::u1, NodalFields::u2})
        if (field == NodalFields::u1 || !fixed_second_field)
          {
            const double F = rhs(index(i, field));
            local[0] += F * F;
            local[1] = std::max(local[1], std::abs(F));
          }
    load_norm        = std::sqrt(Utilities::MPI::sum(local[0], comm));
    multiplier_scale = Utilities::MPI::max(local[1], comm) /
                       std::max(coupling_vector.linfty_norm(),
                                std::numeric_limits<double>::min());

    if (!std::isfinite(rhs.l2_norm()))
      throw InputError(
        "Problem: the load vector is not finite: f1, f2, g1 or g2 evaluate "
        "to NaN or Inf somewhere in the domain");
  }


  void
  ContactSystem::set_gap_stiffness(const double gap_stiffness)
  {
    this->gap_stiffness = gap_stiffness;
  }


  const ContactSystem::Vector &
  ContactSystem::coupling() const
  {
    return coupling_vector;
  }


  void
  ContactSystem::set_stiffness_weights(std::vector<double> weights)
  {
    stiffness_weight = std::move(weights);
  }


  void
  ContactSystem::use_contact_preconditioner(
    const TrilinosWrappers::SparseMatrix &S,
    const double                          mu1,
    const double                          mu2,
    const bool                            higher_order_elements)
  {
    ContactPreconditioner::AdditionalData settings;
    settings.higher_order_elements = higher_order_elements;
    contact_preconditioner = std::make_unique<ContactPreconditioner>(settings);
    contact_preconditioner->initialize_mesh(S, mu1, mu2, coupling_vector, rows);
  }


  bool
  ContactSystem::has_contact_preconditioner() const
  {
    return contact_preconditioner != nullptr;
  }


  const ContactRows &
  ContactSystem::contact_rows() const
  {
    return rows;
  }


  // R(X) = [E X - F ; C(X)]: the rows of the balance equations come from the
  // matrix, whose multiplier rows are then overwritten by the C-function.
  ResidualNorms
  ContactSystem::residual(const Vector &X, Vector &R) const
  {
    TimerOutput::Scope t(timer, "newton: residual");
    matrix.vmult(R, X);
    R -= rhs;
    // The condensed rows of hanging nodes do not hold for the conforming X
    // (its values there come from the constraints, not from those rows).
    double *r = R.begin();
    for (const std::size_t k : condensed_positions)
      r[n_fields * k] = r[n_fields * k + 1] = 0.;

    ResidualNorms norms;
    rows.evaluate(C, X, multiplier_scale, R, norms);

    double local = 0;
    for (std::size_t k = 0; k < owned_nodes.n_elements(); ++k)
      local += r[n_fields * k] * r[n_fields * k] +
               r[n_fields * k + 1] * r[n_fields * k + 1];
    norms.equations = std::sqrt(Utilities::MPI::sum(local, comm)) /
                      std::max(load_norm, std::numeric_limits<double>::min());
    return norms;
  }


  void
  ContactSystem::start_newton()
  {
    if (linear.solver == LinearSolverType::direct)
      direct_solver = std::make_unique<LinearSolver>(linear);
  }


  void
  ContactSystem::setup_jacobian(const Vector &X)
  {
    {
      TimerOutput::Scope t(timer, "newton: jacobian");
      rows.set_linearisation_point(X);
      row_weights = rows.row_weights(C, X, stiffness_weight, multiplier_weight);
      rows.set_jacobian_rows(C, X, matrix, row_weights);
      matrix.compress(VectorOperation::insert);
    }
    TimerOutput::Scope t(timer, "newton: preconditioner");
    if (direct_solver)
      direct_solver->initialize(matrix);
    else if (contact_preconditioner)
      contact_preconditioner->initialize_jacobian(C, X);
    else
      {
        ilu = std::make_unique<TrilinosWrappers::PreconditionILU>();
        ilu->initialize(matrix,
                        TrilinosWrappers::PreconditionILU::AdditionalData(
                          linear.ilu_fill));
      }
  }


  void
  ContactSystem::scale_constraint_rows(Vector &v, const bool divide) const
  {
    double     *x         = v.begin();
    const auto &positions = rows.local_positions();
    for (std::size_t n = 0; n < positions.size(); ++n)
      x[n_fields * positions[n] + 2] *=
        divide ? 1. / row_weights[n] : row_weights[n];
  }


  unsigned int
  ContactSystem::solve(const Vector                        &b,
                       Vector                              &dX,
                       const Gmres<Vector>::Monitor        &monitor,
                       const std::function<bool(Vector &)> &accepted_update,
                       const Gmres<Vector>::Schedule       &schedule)
  {
    // The constraint rows of A carry the row weights: scale b alike.
    Vector weighted_b(b);
    scale_constraint_rows(weighted_b, false);
    if (direct_solver)
      {
        TimerOutput::Scope t(timer, "newton: linear solve");
        return direct_solver->solve(weighted_b, dX);
      }

    Gmres<Vector>::AdditionalData settings;
    settings.max_iterations     = linear.max_iterations;
    settings.krylov_dimension   = linear.krylov_dimension;
    settings.check_interval     = linear.check_interval;
    settings.relative_tolerance = linear_tolerance(nonlinear, linear);
    // On the continuation's path the rows are those of C_mu or of x y = t,
    // which the estimators do not see: an iterate whose estimate would stop
    // GMRES (eta_alg small against eta_lin, which holds the distance from
    // complementarity) need not be a usable direction of the path's
    // system, and Newton would stall on it. GMRES then stops at the forcing
    // term of the inexact strategy, and the estimators judge only the Newton
    // iterates.
    const bool path_step =
      rows.on_path() && monitor && nonlinear.strategy == Strategy::adaptive;
    if (path_step)
      settings.relative_tolerance =
        std::max(settings.relative_tolerance, nonlinear.forcing_term);
    // On the interior-point path the rows x y = t make most of b (all but
    // 1e-4 - 1e-3 of it on seed-smooth), and the exact rows after the
    // solve (doc/reference.md, "Inexact directions") leave GMRES's error in
    // the balance equations: the forcing term then counts against their
    // part of b, as in the inexact interior-point condition of [AG09], but
    // at most ten times tighter (seed-smooth from zero at 1e6 unknowns per
    // field: 23 Newton steps instead of 27, with Newton-min and
    // Fischer-Burmeister; at the end of the path the balance residual had
    // fallen only 2.5 - 3 times per step, and steps were cut to 0.05).
    if (rows.on_path() && nonlinear.strategy == Strategy::inexact)
      settings.relative_tolerance *=
        std::max(balance_fraction(weighted_b, rows.local_positions()), 0.1);

    const auto A = [&](Vector &dst, const Vector &src) {
      matrix.vmult(dst, src);
    };
    Vector     unweighted(b);
    const auto P = [&](Vector &dst, const Vector &src) {
      if (contact_preconditioner)
        {
          // It inverts the unweighted rows.
          unweighted = src;
          scale_constraint_rows(unweighted, true);
          contact_preconditioner->vmult(dst, unweighted);
        }
      else
        ilu->vmult(dst, src);
    };

    TimerOutput::Scope t(timer, "newton: linear solve");
    // On the path no estimate watches GMRES (above).
    Gmres<Vector>::Monitor  watch;
    Gmres<Vector>::Schedule checks;
    if (!path_step)
      {
        watch = monitor;
        if (linear.predict_checks)
          checks = schedule;
      }
    dX = 0;
    const LinearSolveReport report =
      Gmres<Vector>(settings).solve(A, P, dX, weighted_b, watch, checks);
    if (accepted_update && !path_step)
      accepted_update(dX);
    return report.iterations;
  }


  ActiveSetChange
  ContactSystem::active_set(const Vector &X, const bool first)
  {
    return rows.linearised_active_set(C, X, active_rows, !first);
  }


  void
  ContactSystem::attach(SemismoothNewton<Vector> &newton,
                        const ConditionalOStream *progress)
  {
    newton.residual = [this](const Vector &X, Vector &R) {
      return residual(X, R);
    };
    newton.setup_jacobian      = [this](const Vector &X) { setup_jacobian(X); };
    newton.solve_with_jacobian = [this](const Vector &b, Vector &dX) {
      return solve(b, dX);
    };
    newton.active_set = [this](const Vector &X, const bool first) {
      return active_set(X, first);
    };
    rows.attach_continuation(newton, gap_stiffness);
    if (progress)
      newton.monitor = [progress](const NewtonStep &step) {
        *progress << "      k = " << std::setw(2) << step.iteration << ": "
                  << describe(step) << std::endl;
      };
  }


  SemismoothNewton<ContactSystem::Vector>
  ContactSystem::make_newton(const ConditionalOStream *progress)
  {
    SemismoothNewton<Vector> newton(
      typename SemismoothNewton<Vector>::AdditionalData(nonlinear, C));
    start_newton();
    attach(newton, progress);
    return newton;
  }
} // namespace VI
