// What threads gain on a parsed load (doc/performance.md, "Cheaper reads and
// threaded loads"): f1 of a scene's Problem/Expression, evaluated at n points
// on one thread, on two threads sharing one FunctionParser, and on two
// threads with one parsed copy each (what step-membranes does for its loads
// and errors, MembraneProblem::on_cells_with_own_data). All three in one run,
// so the ratios survive a noisy machine; each is the best of five.
//
// Usage: bench_parser_threads [parameters/<scene>.prm] [n]
// (default: parameters/estimators-disk-p1.prm, n = 5e6)

#include <deal.II/base/mpi.h>
#include <deal.II/base/parameter_handler.h>
#include <deal.II/base/thread_management.h>

#include <vi/geometry.h>
#include <vi/parameters.h>
#include <vi/test_cases.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <iomanip>
#include <iostream>
#include <string>

using namespace dealii;

namespace
{
  // The sum of f at points i = begin ... end - 1 of a fixed curve through
  // the unit disk (both branches of the scene's formulas).
  double
  sum_of_values(const Function<2> &f,
                const std::size_t  begin,
                const std::size_t  end)
  {
    double sum = 0;
    for (std::size_t i = begin; i < end; ++i)
      sum +=
        f.value(Point<2>(0.9 * std::sin(1e-3 * i), 0.9 * std::cos(1.7e-3 * i)));
    return sum;
  }

  template <class Work>
  double
  best_seconds(const Work &work)
  {
    double best = 1e300;
    for (unsigned int run = 0; run < 5; ++run)
      {
        const auto start = std::chrono::steady_clock::now();
        work();
        best = std::min(best,
                        std::chrono::duration<double>(
                          std::chrono::steady_clock::now() - start)
                          .count());
      }
    return best;
  }
} // namespace


int
main(int argc, char **argv)
{
  Utilities::MPI::MPI_InitFinalize mpi(argc, argv, 1);
  const std::string                file = argc > 1 ? argv[1] :
                                                     std::string(VI_SOURCE_DIR) +
                                        "/parameters/estimators-disk-p1.prm";
  const std::size_t                n = argc > 2 ? std::stoul(argv[2]) : 5000000;
  try
    {
      ParameterHandler prm;
      VI::ProblemParameters::declare(prm,
                                     VI::membrane_test_case_names(),
                                     "seed-smooth");
      prm.parse_input(file, "", /*skip_undefined=*/true);
      VI::ProblemParameters problem;
      problem.parse(prm);
      const Point<2> center;
      const auto     first  = VI::make_membrane_data<2>(problem, center);
      const auto     second = VI::make_membrane_data<2>(problem, center);

      double     sums[2];
      const auto on_two = [&](const Function<2> &a, const Function<2> &b) {
        Threads::Task<void> other =
          Threads::new_task([&]() { sums[1] = sum_of_values(b, n / 2, n); });
        sums[0] = sum_of_values(a, 0, n / 2);
        other.join();
      };
      const double one =
        best_seconds([&]() { sums[0] = sum_of_values(*first.f1, 0, n); });
      const double reference = sums[0];
      const double shared =
        best_seconds([&]() { on_two(*first.f1, *first.f1); });
      const double own = best_seconds([&]() { on_two(*first.f1, *second.f1); });
      AssertThrow(std::abs(sums[0] + sums[1] - reference) <=
                    1e-12 * std::abs(reference),
                  ExcMessage("the threads summed other values"));
      std::cout << "f1 of " << file << " at " << n << " points (best of 5)\n"
                << std::fixed << std::setprecision(3)
                << "  one thread:                   " << one << " s\n"
                << "  two threads, one parser:      " << shared << " s ("
                << one / shared << "x)\n"
                << "  two threads, a parser each:   " << own << " s ("
                << one / own << "x)\n";
    }
  catch (const std::exception &e)
    {
      std::cerr << "bench_parser_threads: " << e.what() << std::endl;
      return 1;
    }
}
