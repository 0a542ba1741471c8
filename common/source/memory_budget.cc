#include <deal.II/base/mpi.h>
#include <deal.II/base/utilities.h>
#include <deal.II/grid/tria.h>

#include <vi/domain.h>
#include <vi/errors.h>
#include <vi/memory_budget.h>
#include <vi/parameters.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <iomanip>
#include <limits>
#include <sstream>

namespace VI
{
  using namespace dealii;

  namespace
  {
    // The model of a run's memory, measured as the peak resident memory of
    // one process (/usr/bin/time -f %M) of two cycles with nested
    // iteration on seed-smooth, the square, the default estimators, with
    // each linear solver the program offers, against the unknowns (all
    // fields) of the finer mesh (2^r x 2^r cells, r = 7, 8 for Q1, 6, 7 for
    // the others, 5, 6 for SIPG with GMRES + ILU): bench/memory_model.py,
    // whose table doc/data/memory-model.md is. step-parabolic is charged like
    // Q_p with a direct solver: its ring test (parameters/parabolic-ring.prm,
    // three time steps, Initial refinements = 5, 6, 7) costs 2560 bytes per
    // unknown. A process starts at 180 - 215 MB; each unknown then costs the
    // bytes below (the slope between the two runs, made 25 % larger).
    // Degrees beyond the measured ones are charged like the largest
    // measured degree, scaled with the length of a matrix row, which grows
    // like (2p + 1)^2.
    constexpr double bytes_per_process = 2.2e8;

    /// Measured bytes per unknown of a method, times 1.25, by how its
    /// linear systems are solved (Krylov: GMRES; CG for HHO).
    struct Rates
    {
      double direct, krylov_ilu, krylov_amg;

      double
      of(const LinearSolverParameters *linear_solver) const
      {
        if (!linear_solver || linear_solver->solver == LinearSolverType::direct)
          return direct;
        return linear_solver->preconditioner == PreconditionerType::amg ?
                 krylov_amg :
                 krylov_ilu;
      }
    };

    double
    bytes_per_unknown(const Method                  method,
                      const unsigned int            degree,
                      const LinearSolverParameters *linear_solver)
    {
      constexpr Rates q1{3980., 4120., 1830.}, q2{3680., 3840., 1730.},
        sipg{5240., 2870., 1360.}, hho{570., 390., 480.};
      const bool   is_hho = method == Method::hho;
      const bool   dg     = method != Method::fem && !is_hho;
      const Rates &rates  = is_hho ? hho : dg ? sipg : degree == 1 ? q1 : q2;
      const unsigned int measured_degree =
        (is_hho || dg) ? 1 : std::min(degree, 2u);
      const double length = (2. * degree + 1) / (2. * measured_degree + 1);
      return rates.of(linear_solver) * std::max(1., length * length);
    }


    /// The unknowns (all fields) of a mesh of `cells` quadrilaterals: three
    /// nodal fields, and for HHO two fields on about two faces per cell.
    double
    unknowns_per_cell(const Method method, const unsigned int p)
    {
      switch (method)
        {
          case Method::fem:
            return 3. * p * p;
          case Method::hho:
            return 3. * (p + 1) * (p + 2) / 2 + 2. * 2. * p;
          default:
            return 3. * (p + 1) * (p + 1);
        }
    }


    /// A number from the first line of `file` (or from the line of /proc/
    /// meminfo that starts with `key`, in kB), if there is one.
    double
    read_bytes(const std::string &file, const std::string &key = "")
    {
      std::ifstream in(file);
      std::string   line;
      while (std::getline(in, line))
        {
          if (!key.empty() && line.rfind(key, 0) != 0)
            continue;
          std::istringstream numbers(key.empty() ? line :
                                                   line.substr(key.size()));
          double             value = 0;
          if (numbers >> value)
            return key.empty() ? value : 1024. * value;
          return std::numeric_limits<double>::infinity(); // "max"
        }
      return std::numeric_limits<double>::infinity();
    }


    /// MemAvailable, or less if the process's cgroup (v2, else v1) has a
    /// limit: the limit less what the cgroup uses.
    double
    available_bytes()
    {
      double available = read_bytes("/proc/meminfo", "MemAvailable:");
      const std::pair<const char *, const char *> cgroups[] = {
        {"/sys/fs/cgroup/memory.max", "/sys/fs/cgroup/memory.current"},
        {"/sys/fs/cgroup/memory/memory.limit_in_bytes",
         "/sys/fs/cgroup/memory/memory.usage_in_bytes"}};
      for (const auto &[limit, usage] : cgroups)
        {
          const double l = read_bytes(limit), u = read_bytes(usage);
          if (std::isfinite(l) && std::isfinite(u))
            available = std::min(available, l - u);
        }
      return available;
    }
  } // namespace


  MemoryBudget::MemoryBudget(const MeshParameters           &mesh,
                             const DiscretizationParameters &discretization,
                             const LinearSolverParameters   &linear_solver,
                             const MPI_Comm                  comm)
      : MemoryBudget(static_cast<const DomainParameters &>(mesh),
                     mesh.initial_refinements +
                       (mesh.refinement == Refinement::global ?
                          mesh.cycles - 1 :
                          0),
                     discretization,
                     &linear_solver,
                     comm)
  {
    to_lower += " or Mesh/Cycles";
  }


  MemoryBudget::MemoryBudget(const DomainParameters         &mesh,
                             const DiscretizationParameters &discretization,
                             const MPI_Comm                  comm)
      : MemoryBudget(mesh,
                     mesh.initial_refinements,
                     discretization,
                     nullptr,
                     comm)
  {
  }


  MemoryBudget::MemoryBudget(const DomainParameters         &mesh,
                             const unsigned int              levels,
                             const DiscretizationParameters &discretization,
                             const LinearSolverParameters   *linear_solver,
                             const MPI_Comm                  comm)
  {
    Triangulation<2> coarse;
    Domain(mesh).make_coarse_mesh(coarse);
    const unsigned int p = discretization.degree;
    cells                = coarse.n_active_cells() * std::pow(4., levels);
    unknowns             = cells * unknowns_per_cell(discretization.method, p);
    compare_with_machine(
      bytes_per_unknown(discretization.method, p, linear_solver), comm);
  }


  MemoryBudget::MemoryBudget(const double       cells,
                             const double       unknowns,
                             const double       bytes_per_unknown,
                             const std::string &to_lower,
                             const MPI_Comm     comm)
      : cells(cells)
      , unknowns(unknowns)
      , to_lower(to_lower)
  {
    compare_with_machine(bytes_per_unknown, comm);
  }


  void
  MemoryBudget::compare_with_machine(const double   bytes_per_unknown,
                                     const MPI_Comm comm)
  {
    needed = bytes_per_process * Utilities::MPI::n_mpi_processes(comm) +
             bytes_per_unknown * unknowns;
    if (Utilities::MPI::this_mpi_process(comm) == 0)
      available = available_bytes();
    available = Utilities::MPI::broadcast(comm, available, 0);
  }


  void
  MemoryBudget::check() const
  {
    if (needed <= available)
      return;
    std::ostringstream line;
    line << std::setprecision(2) << "the largest mesh has " << cells
         << " cells and " << unknowns << " unknowns and needs about "
         << needed / 1e9 << " GB of memory; lower " << to_lower << " ("
         << available / 1e9 << " GB are available)";
    throw InputError(line.str());
  }
} // namespace VI
