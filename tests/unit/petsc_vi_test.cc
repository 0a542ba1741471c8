// The PETSc SNES VI peer on a complementarity problem with a known solution:
// K = tridiag(-1, 2, -1) (symmetric positive definite), a chosen solution y*
// that is zero on part of the bounded indices, a multiplier m* >= 0 that is
// positive only there, and b = K y* - m*. Then F(y*) = K y* - b = m* is
// complementary to y* on the bounded indices and zero elsewhere, and y* is
// the only solution (K is positive definite).

#include <deal.II/base/index_set.h>
#include <deal.II/lac/dynamic_sparsity_pattern.h>

#include <vi/errors.h>
#include <vi/petsc_vi.h>

#include <gtest/gtest.h>

#include "test_helpers.h"

#include <cmath>
#include <vector>

namespace
{
  using namespace dealii;

  struct Problem
  {
    static constexpr unsigned int n = 41;

    PETScWrappers::MPI::SparseMatrix K;
    PETScWrappers::MPI::Vector       b;
    std::vector<double>              solution;
    IndexSet                         all, bounded;

    Problem()
        : solution(n)
        , all(complete_index_set(n))
        , bounded(n)
    {
      DynamicSparsityPattern pattern(n, n);
      for (unsigned int i = 0; i < n; ++i)
        for (unsigned int j = (i > 0 ? i - 1 : 0); j <= std::min(i + 1, n - 1);
             ++j)
          pattern.add(i, j);
      K.reinit(all, all, pattern, MPI_COMM_SELF);
      for (unsigned int i = 0; i < n; ++i)
        {
          K.set(i, i, 2.);
          if (i > 0)
            K.set(i, i - 1, -1.);
          if (i + 1 < n)
            K.set(i, i + 1, -1.);
        }
      K.compress(VectorOperation::insert);

      // Even indices are bounded below by 0; y* touches the bound on the
      // middle third, with a multiplier there, and is negative at odd
      // indices elsewhere (free variables may be).
      std::vector<double> multiplier(n, 0.);
      for (unsigned int i = 0; i < n; ++i)
        {
          const double x       = (i + 1.) / (n + 1.);
          const bool   contact = (x > 1. / 3. && x < 2. / 3.);
          if (i % 2 == 0)
            {
              bounded.add_index(i);
              solution[i]   = contact ? 0. : 1. + std::sin(7 * x);
              multiplier[i] = contact ? 0.5 + x : 0.;
            }
          else
            solution[i] = std::cos(5 * x) - 0.5;
        }
      PETScWrappers::MPI::Vector y_star(all, MPI_COMM_SELF);
      for (unsigned int i = 0; i < n; ++i)
        y_star(i) = solution[i];
      y_star.compress(VectorOperation::insert);
      b.reinit(all, MPI_COMM_SELF);
      K.vmult(b, y_star);
      for (unsigned int i = 0; i < n; ++i)
        b(i) -= multiplier[i];
      b.compress(VectorOperation::add);
    }

    double
    max_error(const PETScWrappers::MPI::Vector &y) const
    {
      double error = 0;
      for (unsigned int i = 0; i < n; ++i)
        error = std::max(error, std::abs(y(i) - solution[i]));
      return error;
    }
  };


  VI::PetscVIReport
  solve(const Problem                     &problem,
        const VI::PetscVI::AdditionalData &settings,
        PETScWrappers::MPI::Vector        &y)
  {
    y.reinit(problem.all, MPI_COMM_SELF);
    const VI::PetscVI peer(settings);
    return peer.solve(problem.K, problem.b, problem.bounded, y);
  }
} // namespace


TEST(PetscVI, ReducedSpaceActiveSetFindsTheSolution)
{
  const Problem               problem;
  VI::PetscVI::AdditionalData settings;
  PETScWrappers::MPI::Vector  y;
  const VI::PetscVIReport     report = solve(problem, settings, y);
  EXPECT_LT(problem.max_error(y), 1e-10);
  // From y = 0 the active set has to be found: more than one step.
  EXPECT_GT(report.iterations, 1u);
  EXPECT_EQ(report.reason.rfind("CONVERGED", 0), 0u) << report.reason;
}


TEST(PetscVI, SemismoothFischerBurmeisterFindsTheSolution)
{
  const Problem               problem;
  VI::PetscVI::AdditionalData settings;
  settings.type = "ssls";
  PETScWrappers::MPI::Vector y;
  solve(problem, settings, y);
  EXPECT_LT(problem.max_error(y), 1e-9);
}


TEST(PetscVI, IterativeLinearSolvers)
{
  const Problem problem;
  for (const VI::PreconditionerType preconditioner :
       {VI::PreconditionerType::ilu, VI::PreconditionerType::amg})
    {
      VI::PetscVI::AdditionalData settings;
      settings.linear_solver    = VI::LinearSolverType::gmres;
      settings.preconditioner   = preconditioner;
      settings.linear_tolerance = 1e-12;
      PETScWrappers::MPI::Vector y;
      const VI::PetscVIReport    report = solve(problem, settings, y);
      EXPECT_LT(problem.max_error(y), 1e-8) << VI::to_string(preconditioner);
      // At least one Krylov iteration per step (ILU(0) of a tridiagonal
      // matrix is exact: then exactly one).
      EXPECT_GE(report.linear_iterations, report.iterations)
        << VI::to_string(preconditioner);
    }
}


TEST(PetscVI, NonConvergenceIsAFailureThatSaysWhy)
{
  const Problem               problem;
  VI::PetscVI::AdditionalData settings;
  settings.max_iterations = 1;
  PETScWrappers::MPI::Vector y;
  // One step cannot find the active set from y = 0.
  VITest::expect_error_saying<VI::SolverFailure>("DIVERGED_MAX_IT", [&] {
    solve(problem, settings, y);
  });
}


TEST(PetscVI, UnknownTypeIsBadInput)
{
  VI::PetscVI::AdditionalData settings;
  settings.type = "rs";
  EXPECT_THROW(VI::PetscVI peer(settings), VI::InputError);
}
