#include <Amesos.h>
#include <Amesos_BaseSolver.h>
#include <Amesos_Mumps.h>
#include <Epetra_LinearProblem.h>
#include <Teuchos_ParameterList.hpp>
#include <vi/errors.h>
#include <vi/linear_solvers.h>

namespace VI
{
  using namespace dealii;

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
} // namespace VI
