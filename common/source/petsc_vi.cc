#include <deal.II/base/mpi.h>

#include <vi/errors.h>
#include <vi/petsc_vi.h>

#include <petscsnes.h>
#include <string>

namespace VI
{
  namespace
  {
    /// PETSc returns error codes instead of printing its traceback while
    /// this object lives; check() turns a code into one line.
    struct QuietPetscErrors
    {
      QuietPetscErrors()
      {
        PetscPushErrorHandler(PetscReturnErrorHandler, nullptr);
      }
      ~QuietPetscErrors()
      {
        PetscPopErrorHandler();
      }
    };

    void
    check(const PetscErrorCode code, const char *call)
    {
      if (code == 0)
        return;
      const char *text = nullptr;
      PetscErrorMessage(code, &text, nullptr);
      throw SolverFailure(std::string("PETSc SNES VI: ") + call + " failed: " +
                          (text ? text : "error " + std::to_string(code)));
    }

    /// What the callbacks need: F(y) = K y - b, and the Jacobian K, which
    /// SNESVINEWTONSSLS scales in place and so is restored at every step.
    struct Context
    {
      Mat                     K;
      Vec                     b;
      const PetscVI::Monitor *monitor;
    };

    PetscErrorCode
    form_function(SNES, Vec y, Vec F, void *context)
    {
      const auto    &c    = *static_cast<Context *>(context);
      PetscErrorCode code = MatMult(c.K, y, F);
      if (code == 0)
        code = VecAXPY(F, -1., c.b);
      return code;
    }

    PetscErrorCode
    form_jacobian(SNES, Vec, Mat J, Mat, void *context)
    {
      const auto &c = *static_cast<Context *>(context);
      return MatCopy(c.K, J, SAME_NONZERO_PATTERN);
    }

    PetscErrorCode
    monitor_step(SNES snes, PetscInt step, PetscReal norm, void *context)
    {
      const auto          &c      = *static_cast<Context *>(context);
      PetscInt             linear = 0;
      const PetscErrorCode code   = SNESGetLinearSolveIterations(snes, &linear);
      if (code == 0 && *c.monitor)
        (*c.monitor)(step, norm, linear);
      return code;
    }
  } // namespace


  PetscVI::PetscVI(const AdditionalData &settings)
      : settings(settings)
  {
    if (settings.type != "rsls" && settings.type != "ssls")
      throw InputError("PETSc VI type = " + settings.type +
                       ": expected rsls or ssls");
  }


  std::string
  PetscVI::description() const
  {
    std::string linear;
    if (settings.linear_solver == LinearSolverType::direct)
      linear = "MUMPS LU";
    else
      linear = "GMRES + " +
               std::string(settings.preconditioner == PreconditionerType::amg ?
                             "BoomerAMG" :
                             "block ILU");
    return "PETSc SNES vinewton" + settings.type + ", " + linear;
  }


  PetscVIReport
  PetscVI::solve(const dealii::PETScWrappers::MPI::SparseMatrix &K,
                 const dealii::PETScWrappers::MPI::Vector       &b,
                 const dealii::IndexSet                         &bounded,
                 dealii::PETScWrappers::MPI::Vector             &y,
                 const Monitor                                  &monitor) const
  {
    const QuietPetscErrors quiet;
    const MPI_Comm         comm = y.get_mpi_communicator();

    // Bounds: 0 <= y_i for the bounded indices, free elsewhere.
    dealii::PETScWrappers::MPI::Vector lower(y), upper(y);
    lower = PETSC_NINFINITY;
    upper = PETSC_INFINITY;
    for (const auto i : bounded)
      lower(i) = 0.;
    lower.compress(dealii::VectorOperation::insert);

    Mat J;
    check(MatDuplicate(static_cast<Mat>(K), MAT_COPY_VALUES, &J),
          "MatDuplicate");
    dealii::PETScWrappers::MPI::Vector F(y);

    SNES snes;
    check(SNESCreate(comm, &snes), "SNESCreate");
    // Destroy the PETSc objects however this function is left.
    struct Cleanup
    {
      SNES *snes;
      Mat  *J;
      ~Cleanup()
      {
        SNESDestroy(snes);
        MatDestroy(J);
      }
    } cleanup{&snes, &J};

    Context context{static_cast<Mat>(K), b, &monitor};
    check(SNESSetType(snes,
                      settings.type == "rsls" ? SNESVINEWTONRSLS :
                                                SNESVINEWTONSSLS),
          "SNESSetType");
    check(SNESSetFunction(snes, F, form_function, &context), "SNESSetFunction");
    check(SNESSetJacobian(snes, J, J, form_jacobian, &context),
          "SNESSetJacobian");
    check(SNESVISetVariableBounds(snes, lower, upper),
          "SNESVISetVariableBounds");
    // Absolute stopping on the norm SNES VI monitors (for RSLS the residual
    // of the inactive rows, for SSLS the Fischer-Burmeister residual),
    // relative to |b| as our Newton's residuals are relative to the load.
    check(SNESSetTolerances(snes,
                            settings.tolerance * b.l2_norm(),
                            0.,
                            0.,
                            settings.max_iterations,
                            100 * settings.max_iterations + 1000),
          "SNESSetTolerances");

    KSP ksp;
    PC  pc;
    check(SNESGetKSP(snes, &ksp), "SNESGetKSP");
    check(KSPGetPC(ksp, &pc), "KSPGetPC");
    if (settings.linear_solver == LinearSolverType::direct)
      {
        check(KSPSetType(ksp, KSPPREONLY), "KSPSetType");
        check(PCSetType(pc, PCLU), "PCSetType");
        check(PCFactorSetMatSolverType(pc, MATSOLVERMUMPS),
              "PCFactorSetMatSolverType");
      }
    else
      {
        check(KSPSetType(ksp, KSPGMRES), "KSPSetType");
        check(KSPGMRESSetRestart(ksp, settings.krylov_dimension),
              "KSPGMRESSetRestart");
        check(KSPSetTolerances(ksp,
                               settings.linear_tolerance,
                               PETSC_DEFAULT,
                               PETSC_DEFAULT,
                               settings.max_linear_iterations),
              "KSPSetTolerances");
        if (settings.preconditioner == PreconditionerType::amg)
          {
            check(PCSetType(pc, PCHYPRE), "PCSetType");
            check(PCHYPRESetType(pc, "boomeramg"), "PCHYPRESetType");
          }
        else
          {
            // ILU of each process's block (PETSc's ILU does not take the
            // MPI matrix type, even on one process); the fill level goes
            // to the blocks, created later, through the options database.
            check(PCSetType(pc, PCBJACOBI), "PCSetType");
            PetscBool user_set = PETSC_FALSE;
            check(PetscOptionsHasName(
                    nullptr, nullptr, "-sub_pc_factor_levels", &user_set),
                  "PetscOptionsHasName");
            if (!user_set)
              check(
                PetscOptionsSetValue(nullptr,
                                     "-sub_pc_factor_levels",
                                     std::to_string(settings.ilu_fill).c_str()),
                "PetscOptionsSetValue");
          }
      }
    if (monitor)
      check(SNESMonitorSet(snes, monitor_step, &context, nullptr),
            "SNESMonitorSet");
    check(SNESSetFromOptions(snes), "SNESSetFromOptions");

    check(SNESSolve(snes, nullptr, y), "SNESSolve");

    PetscInt            iterations = 0, linear = 0;
    SNESConvergedReason reason;
    check(SNESGetIterationNumber(snes, &iterations), "SNESGetIterationNumber");
    check(SNESGetLinearSolveIterations(snes, &linear),
          "SNESGetLinearSolveIterations");
    check(SNESGetConvergedReason(snes, &reason), "SNESGetConvergedReason");

    PetscVIReport report;
    report.iterations        = iterations;
    report.linear_iterations = linear;
    report.reason            = SNESConvergedReasons[reason];
    if (reason <= 0)
      throw SolverFailure(description() + " did not converge after " +
                          std::to_string(iterations) +
                          " iterations: " + report.reason);
    return report;
  }
} // namespace VI
