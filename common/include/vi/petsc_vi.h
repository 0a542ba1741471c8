#pragma once

#include <deal.II/base/index_set.h>
#include <deal.II/lac/petsc_sparse_matrix.h>
#include <deal.II/lac/petsc_vector.h>

#include <vi/parameters.h>

#include <functional>
#include <string>

namespace VI
{
  /// What PETSc's SNES VI did.
  struct PetscVIReport
  {
    unsigned int iterations        = 0; ///< nonlinear (active-set) steps
    unsigned int linear_iterations = 0; ///< all KSP iterations
    std::string  reason; ///< SNESConvergedReason, e.g. CONVERGED_FNORM_ABS
  };


  /**
   * The peer solver: PETSc's SNES VI applied to the linear mixed
   * complementarity problem
   *
   *   y_i >= 0, F_i(y) >= 0, y_i F_i(y) = 0   for i in `bounded`,
   *   F_i(y) = 0                               otherwise,
   *   F(y) = K y - b,
   *
   * with SNESVINEWTONRSLS (reduced-space active set: Newton on the inactive
   * rows, the active variables held at the bound) or SNESVINEWTONSSLS
   * (semismooth Newton on the Fischer-Burmeister reformulation with a line
   * search). It is independent of the membrane problems: any PETSc matrix
   * and right-hand side, solved through the PETSc C API on deal.II's
   * PETScWrappers objects. The options database is read last
   * (SNESSetFromOptions), so PETSC_OPTIONS="-snes_monitor -ksp_type cg ..."
   * overrides everything set here.
   */
  class PetscVI
  {
  public:
    struct AdditionalData
    {
      std::string type = "rsls"; ///< rsls | ssls
      /// direct (MUMPS LU of each reduced system) or gmres.
      LinearSolverType   linear_solver = LinearSolverType::direct;
      PreconditionerType preconditioner =
        PreconditionerType::amg; ///< BoomerAMG | ILU
      unsigned int ilu_fill = 0;
      /// Relative KSP tolerance; and the restart length of GMRES.
      double       linear_tolerance      = 1e-12;
      unsigned int max_linear_iterations = 2000;
      unsigned int krylov_dimension      = 200;
      /// Stop when the norm SNES VI monitors is below tolerance |b|.
      double       tolerance      = 1e-10;
      unsigned int max_iterations = 50;
    };

    /// Called after every nonlinear step with the step number, the norm
    /// SNES VI monitors and the KSP iterations so far.
    using Monitor = std::function<
      void(unsigned int step, double residual, unsigned int linear)>;

    explicit PetscVI(const AdditionalData &settings);

    /**
     * Solve from the initial guess y (projected onto the bounds by PETSc).
     * Throws SolverFailure, with PETSc's reason, when SNES does not
     * converge or PETSc reports an error; y is then not a solution.
     */
    PetscVIReport
    solve(const dealii::PETScWrappers::MPI::SparseMatrix &K,
          const dealii::PETScWrappers::MPI::Vector       &b,
          const dealii::IndexSet                         &bounded,
          dealii::PETScWrappers::MPI::Vector             &y,
          const Monitor &monitor = nullptr) const;

    /// "PETSc SNES vinewtonrsls, MUMPS LU" and the like, for headers.
    std::string
    description() const;

  private:
    AdditionalData settings;
  };
} // namespace VI
