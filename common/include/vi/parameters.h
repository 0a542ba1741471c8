#pragma once

#include <deal.II/base/parameter_handler.h>
#include <deal.II/base/types.h>

#include <vi/complementarity.h>
#include <vi/semismooth_newton.h>

#include <string>
#include <vector>

namespace VI
{
  /**
   * The choices of the .prm files, parsed once into these enums (the .prm
   * spelling is what to_string() gives back, for output and messages).
   */
  /// Discretization/Method.
  enum class Method
  {
    fem,
    sipg,
    nipg,
    iipg,
    hho
  };

  /// Nonlinear solver/Strategy: how exactly each Newton step is solved.
  enum class Strategy
  {
    exact,    ///< to Linear solver/Tolerance
    inexact,  ///< to the forcing term
    adaptive, ///< until the estimators say the algebraic error is small
  };

  /// Nonlinear solver/Initial guess: where Newton starts on a first mesh.
  enum class InitialGuess
  {
    zero, ///< zero interior values and multiplier, the boundary data imposed
    data, ///< u1h, u2h interpolate g1, g2 in the whole domain, multiplier 0
  };

  /// Problem/Model: what lies under membrane 1.
  enum class Model
  {
    two_membranes, ///< a second membrane (u2, mu2, f2, g2)
    obstacle,      ///< a rigid obstacle: u1 >= Problem/Expression/obstacle
  };

  /// Linear solver/Solver.
  enum class LinearSolverType
  {
    direct,
    gmres,
    cg
  };

  /// Linear solver/Preconditioner.
  enum class PreconditionerType
  {
    ilu,
    amg
  };

  /// Mesh/Refinement: how the mesh changes between cycles.
  enum class Refinement
  {
    global,   ///< every cell
    adaptive, ///< the cells the estimate marks (Mesh/Marking)
  };

  /// Mesh/Marking: which cells adaptive refinement marks.
  enum class Marking
  {
    dorfler,        ///< the fewest cells that carry the fraction of eta^2
    fixed_fraction, ///< the fraction of the cells with the largest indicators
  };

  std::string
  to_string(const Method method);
  std::string
  to_string(const Strategy strategy);
  std::string
  to_string(const LinearSolverType solver);
  std::string
  to_string(const PreconditionerType preconditioner);

  /**
   * The parameter sections shared by the programs (their names are the
   * interface of every scene in parameters/). Each section declares its entries
   * with documentation and a pattern, and parses them with the checks a pattern
   * cannot express (positivity, consistency); a violation throws InputError
   * naming the parameter. A program declares the sections it needs and may
   * restrict the accepted values (e.g. the discretisation methods it
   * implements).
   */

  /**
   * The subsection `name` of `prm`, entered for the lifetime of this object:
   * a declare() or parse() leaves it on every way out, an InputError
   * included.
   */
  class ParameterSubsection
  {
  public:
    ParameterSubsection(dealii::ParameterHandler &prm, const std::string &name);
    ~ParameterSubsection();
    ParameterSubsection(const ParameterSubsection &) = delete;
    ParameterSubsection &
    operator=(const ParameterSubsection &) = delete;

  private:
    dealii::ParameterHandler &prm;
  };


  /**
   * Paths in a parameter file (Mesh/File) are relative to the file's folder:
   * run_program() records the folder of the file it reads, and
   * parameter_path() resolves a path against it (absolute paths, and paths
   * when no file was read, are left as they are).
   */
  void
  set_parameter_directory(const std::string &directory);
  std::string
  parameter_path(const std::string &path);


  struct ExpressionParameters
  {
    std::string f1, f2, g1, g2;
    std::string u1, u2, lambda; ///< exact solution; empty = unknown
    std::string obstacle;       ///< with Model = obstacle
    std::string constants;      ///< "name=value, name=value"
  };


  /// Problem/Dirichlet boundary ids and Problem/Friedrichs constant: where
  /// the membranes are clamped (VI::Domain checks them against the mesh).
  struct BoundaryParameters
  {
    bool                                    clamped_everywhere = true;
    std::vector<dealii::types::boundary_id> dirichlet_ids;
    double friedrichs_constant = 0; ///< 0: the domain's own (auto)

    static void
    declare(dealii::ParameterHandler &prm);
    void
    parse(dealii::ParameterHandler &prm);
  };


  struct ProblemParameters
  {
    std::string test_case = "seed-smooth";
    Model       model     = Model::two_membranes;
    double      mu1       = 1.;
    double      mu2       = 1.;
    /// Model = obstacle: the obstacle is twice differentiable where the
    /// discrete solution dips below it (Problem/Smooth obstacle).
    bool                 smooth_obstacle = false;
    ExpressionParameters expression;
    BoundaryParameters   boundary;

    /// `variables`: how the documentation names the variables of the
    /// expressions ("x, y"; "x, y, t" for time-dependent problems).
    static void
    declare(dealii::ParameterHandler &prm,
            const std::string        &test_cases,
            const std::string        &default_test_case,
            const std::string        &variables = "x, y");
    void
    parse(dealii::ParameterHandler &prm);
  };


  /// Mesh/Geometry and Mesh/Initial refinements: the domain and its coarse
  /// mesh, the part of the Mesh section every program has.
  struct DomainParameters
  {
    std::string  geometry            = "square";
    std::string  file                = ""; ///< resolved, see parameter_path()
    unsigned int initial_refinements = 3;

    /// `refinements_doc`: what the initial refinements are to the program.
    static void
    declare(dealii::ParameterHandler &prm,
            const std::string        &default_geometry,
            const std::string        &default_refinements,
            const std::string        &refinements_doc);
    void
    parse(dealii::ParameterHandler &prm);
  };


  /// The Mesh section of the programs that solve on a sequence of meshes.
  struct MeshParameters : DomainParameters
  {
    Refinement   refinement          = Refinement::global;
    Marking      marking             = Marking::dorfler;
    double       refinement_fraction = 0.5;
    unsigned int cycles              = 5;

    static void
    declare(dealii::ParameterHandler &prm);
    void
    parse(dealii::ParameterHandler &prm);
  };


  struct DiscretizationParameters
  {
    Method       method = Method::fem;
    unsigned int degree = 1;

    static void
    declare(dealii::ParameterHandler &prm, const std::string &methods);
    void
    parse(dealii::ParameterHandler &prm);
  };


  struct NonlinearSolverParameters
  {
    ComplementarityFunction::Type c_function =
      ComplementarityFunction::Type::min;
    Strategy           strategy            = Strategy::exact;
    double             gamma_lin           = 0.3;
    double             gamma_alg           = 0.3;
    double             forcing_term        = 1e-2;
    unsigned int       max_iterations      = 50;
    double             tolerance           = 1e-10;
    unsigned int       watchdog_steps      = 8; ///< step-twophase only
    bool               continuation        = true;
    ContinuationMethod continuation_method = ContinuationMethod::interior_point;
    bool               nested_iteration    = true;
    InitialGuess       initial_guess       = InitialGuess::zero;

    /// The stopping tests of the adaptive strategy [DMV20]: the algebraic
    /// error is small enough when eta_alg <= gamma_alg max(eta_disc,
    /// eta_lin) (stops GMRES), the linearisation error when
    /// eta_lin <= gamma_lin eta_disc (stops Newton).
    bool
    algebraic_error_small(const double eta_disc,
                          const double eta_lin,
                          const double eta_alg) const;
    /// The bound of the algebraic test, gamma_alg max(eta_disc, eta_lin).
    double
    algebraic_threshold(const double eta_disc, const double eta_lin) const;
    bool
    linearisation_error_small(const double eta_disc,
                              const double eta_lin) const;

    /// `strategies`: the accepted values of "Strategy", e.g. "exact" or
    /// "exact|inexact|adaptive". `mesh_starts`: whether the program lets
    /// the user choose where Newton starts on each mesh ("Nested
    /// iteration", "Initial guess"); step-parabolic and step-twophase start
    /// every time step from the previous one and do not declare them.
    static void
    declare(dealii::ParameterHandler &prm,
            const std::string        &strategies,
            const bool                mesh_starts = true);
    void
    parse(dealii::ParameterHandler &prm, const bool mesh_starts = true);
  };


  struct LinearSolverParameters
  {
    LinearSolverType   solver           = LinearSolverType::direct;
    PreconditionerType preconditioner   = PreconditionerType::ilu;
    std::string        direct_package   = "Amesos_Mumps";
    double             tolerance        = 1e-12;
    unsigned int       max_iterations   = 2000;
    unsigned int       krylov_dimension = 200;
    unsigned int       check_interval   = 10;
    bool               predict_checks   = true;
    unsigned int       ilu_fill         = 0;

    /// `solvers`: the accepted values of "Solver" ("direct", "direct|gmres").
    static void
    declare(dealii::ParameterHandler &prm,
            const std::string        &solvers        = "direct",
            const std::string        &default_solver = "direct");
    void
    parse(dealii::ParameterHandler &prm);
  };


  /// Relative tolerance of the linear solve in each Newton step: the forcing
  /// term for the inexact strategy, Linear solver/Tolerance otherwise (the
  /// adaptive strategy stops earlier, on its estimators).
  double
  linear_tolerance(const NonlinearSolverParameters &nonlinear,
                   const LinearSolverParameters    &linear);


  struct EstimatorParameters
  {
    bool enabled     = true;
    bool every_check = true;
    /// The multiplier of the estimate for p >= 2: on the contact cells
    /// (CellMultiplier) or the finite element function M^(-1) m.
    enum class Multiplier
    {
      contact_cells,
      conforming
    } multiplier = Multiplier::contact_cells;
    /// Estimators/Flux degree: the fluxes of elements of degree p in
    /// RT_p x Q_p ([DMV20]) or in RT_(p-1) x Q_(p-1).
    enum class FluxDegree
    {
      p,
      p_minus_1
    } flux_degree = FluxDegree::p;
    /// The degree k of the fluxes RT_k for elements of degree p.
    unsigned int
    flux_degree_for(const unsigned int p) const
    {
      return flux_degree == FluxDegree::p ? p : p - 1;
    }
    /// Dual norms bounded by equilibration (DualNormBound): of the cell
    /// means of the multiplier's undershoots, of the algebraic remainder.
    bool dual_norm_undershoots = false, dual_norm_remainder = false;
    /// Adaptive strategy: skip the flux reconstruction of a check whose
    /// flux-free terms already decide it (GMRES stops, Newton goes on).
    bool defer_fluxes = true;
    /// The estimate each solve ends with computed once more with both dual
    /// norms bounded by equilibration; the smaller bound is reported.
    bool sharpen_final = false;
    /// Estimators/Transmitted load: whether the estimate's multiplier
    /// carries the transmitted load on cells at the contact set
    /// (TransmittedLoad).
    enum class TransmittedLoad
    {
      automatic, ///< for tensions more than 10 times apart
      always,
      never
    } transmitted_load = TransmittedLoad::automatic;
    /// Whether Estimators/Transmitted load takes it for tensions mu1, mu2.
    bool
    transmits_load(const double mu1, const double mu2) const;
    /// Whether an estimate of FEM of degree p with tensions mu1, mu2 uses
    /// the transmitted load (for p >= 2 only with the cellwise multiplier).
    /// With `every_contact_cell` (the load on every cell with a node in the
    /// contact set, as step-parabolic puts it), `auto` takes it for p >= 2
    /// at any ratio: there it is the sharper bound at equal tensions too.
    bool
    uses_transmitted_load(const double       mu1,
                          const double       mu2,
                          const unsigned int p,
                          const bool         every_contact_cell = false) const;
    bool
    equilibrated_dual_norms() const
    {
      return dual_norm_undershoots || dual_norm_remainder;
    }
    /// Whether any estimate bounds dual norms by equilibration.
    bool
    needs_dual_norm_bound() const
    {
      return equilibrated_dual_norms() || sharpen_final;
    }

    static void
    declare(dealii::ParameterHandler &prm);
    void
    parse(dealii::ParameterHandler &prm);
  };


  /**
   * What reads the estimate needs the estimators: Mesh/Refinement =
   * adaptive marks the cells with it (checked when `mesh` is given), and
   * Nonlinear solver/Strategy = adaptive stops the solvers with it. Throws
   * the InputError that asks for Estimators/Enabled = true when
   * `estimators_enabled` is false and one of them is chosen.
   */
  void
  require_estimators_where_read(const MeshParameters *mesh,
                                const Strategy        strategy,
                                const bool            estimators_enabled);


  struct OutputParameters
  {
    std::string directory = "output";
    bool        write_vtu = true;
    bool        verbose   = false;

    static void
    declare(dealii::ParameterHandler &prm);
    void
    parse(dealii::ParameterHandler &prm);
  };
} // namespace VI
