#include <deal.II/lac/full_matrix.h>
#include <deal.II/lac/vector.h>

#include <vi/errors.h>
#include <vi/linear_solvers.h>

#include <Amesos.h>
#include <Amesos_BaseSolver.h>
#include <Amesos_Mumps.h>
#include <Epetra_LinearProblem.h>
#include <Teuchos_ParameterList.hpp>

#include <cmath>
#include <sstream>
#include <vector>

namespace VI
{
  using namespace dealii;

  namespace
  {
    /// Apply the rotations of the columns before j to column j of the
    /// Hessenberg matrix, then the one that zeroes its subdiagonal entry
    /// h_next; update the rotated right-hand side g.
    void
    rotate_column(FullMatrix<double>  &H,
                  std::vector<double> &cs,
                  std::vector<double> &sn,
                  std::vector<double> &g,
                  const unsigned int   j,
                  const double         h_next)
    {
      for (unsigned int i = 0; i < j; ++i)
        {
          const double a = H(i, j), c = H(i + 1, j);
          H(i, j)     = cs[i] * a + sn[i] * c;
          H(i + 1, j) = -sn[i] * a + cs[i] * c;
        }
      const double r = std::hypot(H(j, j), h_next);
      cs[j]          = H(j, j) / r;
      sn[j]          = h_next / r;
      H(j, j)        = r;
      g[j + 1]       = -sn[j] * g[j];
      g[j]           = cs[j] * g[j];
    }


    /// y_j solving the upper triangular system H_j y = g_j of j columns.
    void
    solve_triangular(const FullMatrix<double>  &H,
                     const std::vector<double> &g,
                     std::vector<double>       &y,
                     const unsigned int         j)
    {
      for (int i = int(j) - 1; i >= 0; --i)
        {
          double sum = g[i];
          for (unsigned int l = i + 1; l < j; ++l)
            sum -= H(i, l) * y[l];
          y[i] = sum / H(i, i);
        }
    }


    /// Orthogonalise V[j + 1] against V[0..j] by modified Gram-Schmidt,
    /// twice (for the loss of orthogonality on long cycles), into column j
    /// of H.
    template <typename VectorType>
    void
    orthogonalise(std::vector<VectorType> &V,
                  FullMatrix<double>      &H,
                  const unsigned int       j)
    {
      for (unsigned int i = 0; i <= j; ++i)
        H(i, j) = 0;
      for (unsigned int pass = 0; pass < 2; ++pass)
        for (unsigned int i = 0; i <= j; ++i)
          {
            const double h = V[j + 1] * V[i];
            H(i, j) += h;
            V[j + 1].add(-h, V[i]);
          }
    }
  } // namespace


  template <typename VectorType>
  Gmres<VectorType>::Gmres(const AdditionalData &data)
      : data(data)
  {
  }


  template <typename VectorType>
  LinearSolveReport
  Gmres<VectorType>::solve(const Operator   &A,
                           const Operator   &preconditioner,
                           VectorType       &x,
                           const VectorType &b,
                           const Monitor    &monitor,
                           const Schedule   &schedule) const
  {
    const unsigned int m = std::max(1u, data.krylov_dimension);
    LinearSolveReport  report;

    // Krylov basis V (m + 1 vectors), Hessenberg matrix after the Givens
    // rotations (upper triangular in its first j columns), the rotations,
    // and the rotated right-hand side g, |g_{j+1}| = |b - A x^j|.
    // The basis vectors are allocated when the Arnoldi process first
    // reaches them: with a good preconditioner a solve needs a few tens of
    // the m + 1 (200 by default), which would otherwise cost 200 vectors of
    // memory (1.6 kB per unknown).
    std::vector<VectorType> V(m + 1);
    const auto basis_vector = [&](const unsigned int i) -> VectorType & {
      if (V[i].size() != b.size())
        V[i].reinit(b, /*omit_zeroing_entries=*/true);
      return V[i];
    };
    VectorType w, z, correction;
    w.reinit(b, true);
    z.reinit(b, true);
    correction.reinit(b, true);
    FullMatrix<double>  H(m + 1, m);
    std::vector<double> cs(m), sn(m), g(m + 1), y(m);

    // x^j = x0 + P^{-1} V_j y_j, y_j solving the triangular system.
    const auto iterate = [&](const unsigned int j, VectorType &result) {
      solve_triangular(H, g, y, j);
      w = 0;
      for (unsigned int i = 0; i < j; ++i)
        w.add(y[i], V[i]);
      preconditioner(correction, w);
      result = x;
      result += correction;
    };

    VectorType current;
    current.reinit(b, true);

    double       tolerance  = 0;
    unsigned int last_check = 0;
    // Set when a cycle ended because its recurrence residual met the
    // tolerance, with the true residual it started from.
    bool   recurrence_converged = false;
    double cycle_start_residual = 0;
    for (bool first_cycle = true;; first_cycle = false)
      {
        // r0 = b - A x, V_0 = r0 / |r0|
        A(basis_vector(0), x);
        V[0].sadd(-1., 1., b);
        const double beta = V[0].l2_norm();
        if (first_cycle)
          {
            report.initial_residual = beta;
            tolerance =
              std::max(data.absolute_tolerance, data.relative_tolerance * beta);
          }
        report.final_residual = beta;
        if (!std::isfinite(beta))
          throw SolverFailure("GMRES: the residual is not a number");
        if (beta <= tolerance || beta == 0.)
          return report;
        // The recurrence said converged but the true residual did not
        // follow: it is at the level of the rounding errors of A x and of
        // the preconditioner (or the preconditioner is not a fixed linear
        // operator), and more cycles would repeat the same Krylov steps
        // (they did, to max_iterations, on the Jacobians of step-twophase
        // from 1e4 cells on). The iterate is as exact as the arithmetic
        // allows; the caller's outer iteration judges it.
        if (recurrence_converged && beta > 0.5 * cycle_start_residual)
          {
            report.outcome = LinearSolveReport::Outcome::stagnated;
            return report;
          }
        cycle_start_residual = beta;
        recurrence_converged = false;
        if (report.iterations >= data.max_iterations)
          break;
        V[0] /= beta;
        std::fill(g.begin(), g.end(), 0.);
        g[0] = beta;

        unsigned int j    = 0;
        bool         stop = false;
        for (; j < m && report.iterations < data.max_iterations; ++j)
          {
            // Arnoldi step
            preconditioner(z, V[j]);
            A(basis_vector(j + 1), z);
            orthogonalise(V, H, j);
            const double h_next = V[j + 1].l2_norm();

            rotate_column(H, cs, sn, g, j, h_next);
            ++report.iterations;
            report.final_residual = std::abs(g[j + 1]);

            const bool breakdown = h_next <= 1e-14 * H(j, j);
            if (!breakdown)
              V[j + 1] /= h_next;

            if (report.final_residual <= tolerance || breakdown)
              {
                recurrence_converged = true;
                ++j;
                break;
              }
            // The schedule is asked at every iteration: it may keep the
            // residuals it sees.
            const bool asked = schedule && schedule(report.iterations,
                                                    report.final_residual,
                                                    report.initial_residual);
            if (monitor && (asked || report.iterations - last_check >=
                                       data.check_interval))
              {
                last_check = report.iterations;
                iterate(j + 1, current);
                if (monitor(current, report.iterations))
                  {
                    x = current;
                    report.outcome =
                      LinearSolveReport::Outcome::stopped_by_caller;
                    stop = true;
                    break;
                  }
              }
          }
        if (stop)
          return report;
        // End of a cycle: x = x0 + P^{-1} V y; the loop recomputes the true
        // residual (and returns if it is small enough).
        iterate(j, current);
        x = current;
      }

    std::ostringstream message;
    message << "GMRES: no convergence in " << data.max_iterations
            << " iterations (residual reduced from " << report.initial_residual
            << " to " << report.final_residual << ", tolerance " << tolerance
            << ")";
    throw SolverFailure(message.str());
  }


  template class Gmres<Vector<double>>;
  template class Gmres<TrilinosWrappers::MPI::Vector>;

  LinearSolver::LinearSolver(const LinearSolverParameters &parameters)
      : parameters(parameters)
  {
  }


  LinearSolver::~LinearSolver() = default;


  void
  LinearSolver::initialize(const TrilinosWrappers::SparseMatrix &A)
  {
    const std::string &package = parameters.direct_package;
    auto              *mumps   = dynamic_cast<Amesos_Mumps *>(direct.get());

    // MUMPS reads its controls in the analysis phase only; ICNTL(14) is the
    // percentage of workspace added to the estimate of that phase.
    const auto analyse = [&]() {
      if (mumps)
        mumps->SetICNTL(14, mumps_extra_workspace);
      if (direct->SymbolicFactorization() != 0)
        throw SolverFailure("direct solver " + package +
                            ": symbolic factorisation failed");
    };

    if (matrix != &A)
      {
        matrix  = &A;
        problem = std::make_unique<Epetra_LinearProblem>();
        problem->SetOperator(
          const_cast<Epetra_CrsMatrix *>(&A.trilinos_matrix()));
        Amesos factory;
        if (!factory.Query(package.c_str()))
          throw SolverFailure("direct solver " + package +
                              " is not available in this Trilinos");
        direct.reset(factory.Create(package.c_str(), *problem));
        Teuchos::ParameterList settings;
        settings.set("PrintStatus", false);
        settings.set("PrintTiming", false);
        direct->SetParameters(settings);
        mumps = dynamic_cast<Amesos_Mumps *>(direct.get());
        analyse();
      }

    for (unsigned int attempt = 0;; ++attempt)
      {
        if (direct->NumericFactorization() == 0)
          return;
        if (!mumps || attempt == 3)
          throw SolverFailure("direct solver " + package +
                              ": numeric factorisation failed (singular "
                              "generalised Jacobian?)");
        mumps_extra_workspace *= 3;
        analyse();
      }
  }


  unsigned int
  LinearSolver::solve(const TrilinosWrappers::MPI::Vector &b,
                      TrilinosWrappers::MPI::Vector       &x)
  {
    Assert(direct, ExcMessage("initialize() the solver first"));
    problem->SetLHS(&x.trilinos_vector());
    problem->SetRHS(const_cast<Epetra_MultiVector *>(
      static_cast<const Epetra_MultiVector *>(&b.trilinos_vector())));
    if (direct->Solve() != 0)
      throw SolverFailure("direct solver " + parameters.direct_package +
                          ": the solve failed");
    return 0;
  }


  TrilinosWrappers::PreconditionAMG::AdditionalData
  elliptic_amg_settings(const bool higher_order_elements)
  {
    TrilinosWrappers::PreconditionAMG::AdditionalData settings;
    settings.elliptic              = true;
    settings.higher_order_elements = higher_order_elements;
    settings.smoother_sweeps       = 2;
    settings.aggregation_threshold = 0.02;
    return settings;
  }
} // namespace VI
