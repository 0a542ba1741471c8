// What a parsed expression costs (doc/performance.md, "Parsed expressions
// without a lock per point"): the formulas of a scene evaluated through
// deal.II's FunctionParser (as the programs did before VI::ExpressionFunction)
// and through VI::ExpressionFunction, in lists of 16 points (a cell of the
// Q1 error quadrature), values of f1 and fourth-order gradients of u1 (f1
// if the scene has no exact solution), on one thread and on two threads
// sharing one object. All in one run, so the ratios survive a noisy
// machine; each time is the best of five. The two must give the same
// numbers to the last bit (checked).
//
// Usage: bench_expression_evaluation [parameters/<scene>.prm] [n]
// (default: parameters/estimators-disk-p1.prm, n = 2e6 points)

#include <deal.II/base/function_parser.h>
#include <deal.II/base/mpi.h>
#include <deal.II/base/parameter_handler.h>
#include <deal.II/base/thread_management.h>

#include <vi/expression_function.h>
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
  constexpr unsigned int list_size = 16;

  // Points i = begin ... end - 1 of a fixed curve through the unit disk
  // (both branches of the disk scene's formulas), in lists of 16, and the
  // sum of what `evaluate` gives for each list.
  template <class Evaluate>
  double
  sum_over_lists(const Evaluate   &evaluate,
                 const std::size_t begin,
                 const std::size_t end)
  {
    std::vector<Point<2>> points(list_size);
    double                sum = 0;
    for (std::size_t i = begin; i + list_size <= end; i += list_size)
      {
        for (unsigned int q = 0; q < list_size; ++q)
          points[q] = Point<2>(0.9 * std::sin(1e-3 * (i + q)),
                               0.9 * std::cos(1.7e-3 * (i + q)));
        sum += evaluate(points);
      }
    return sum;
  }

  double
  values(const Function<2> &f, const std::size_t begin, const std::size_t end)
  {
    std::vector<double> v(list_size);
    return sum_over_lists(
      [&](const std::vector<Point<2>> &points) {
        f.value_list(points, v);
        double s = 0;
        for (const double x : v)
          s += x;
        return s;
      },
      begin,
      end);
  }

  double
  gradients(const Function<2> &f,
            const std::size_t  begin,
            const std::size_t  end)
  {
    std::vector<Tensor<1, 2>> g(list_size);
    return sum_over_lists(
      [&](const std::vector<Point<2>> &points) {
        f.gradient_list(points, g);
        double s = 0;
        for (const auto &x : g)
          s += x[0] + 0.5 * x[1];
        return s;
      },
      begin,
      end);
  }

  // The best of five wall times of `work` and the sum it returned.
  template <class Work>
  std::pair<double, double>
  best_of_five(const Work &work)
  {
    double best = 1e300, sum = 0;
    for (unsigned int run = 0; run < 5; ++run)
      {
        const auto start = std::chrono::steady_clock::now();
        sum              = work();
        best             = std::min(best,
                        std::chrono::duration<double>(
                          std::chrono::steady_clock::now() - start)
                          .count());
      }
    return {best, sum};
  }
} // namespace


int
main(int argc, char **argv)
{
  Utilities::MPI::MPI_InitFinalize mpi(argc,
                                       argv,
                                       numbers::invalid_unsigned_int);
  const std::string                file = argc > 1 ? argv[1] :
                                                     std::string(VI_SOURCE_DIR) +
                                        "/parameters/estimators-disk-p1.prm";
  const std::size_t                n = argc > 2 ? std::stoul(argv[2]) : 2000000;
  try
    {
      ParameterHandler prm;
      VI::ProblemParameters::declare(prm,
                                     VI::membrane_test_case_names(),
                                     "seed-smooth");
      prm.parse_input(file, "", /*skip_undefined=*/true);
      VI::ProblemParameters problem;
      problem.parse(prm);
      if (problem.test_case != "expression")
        throw std::runtime_error(file + " has no Problem/Expression");
      const auto       &e         = problem.expression;
      const auto        constants = VI::parse_expression_constants(e.constants);
      const std::string differentiated = e.u1.empty() ? e.f1 : e.u1;

      FunctionParser<2> parser_f(1, 0., 1e-4), parser_u(1, 0., 1e-4);
      parser_u.set_formula(AutoDerivativeFunction<2>::FourthOrder);
      parser_f.initialize("x,y", e.f1, constants);
      parser_u.initialize("x,y", differentiated, constants);
      const VI::ExpressionFunction<2> expression_f(
        e.f1, constants, Point<2>(), false, 1e-4);
      const VI::ExpressionFunction<2> expression_u(
        differentiated, constants, Point<2>(), false, 1e-4);

      std::cout << "Problem/Expression of "
                << (argc > 1 ? file :
                               std::string("parameters/estimators-disk-p1.prm"))
                << ", " << n << " points in lists of " << list_size
                << " (best of 5 runs, seconds)\n\n"
                << "| evaluation | threads | FunctionParser | "
                   "ExpressionFunction | ratio |\n"
                << "|---|---|---|---|---|\n"
                << std::fixed;
      bool same = true;
      for (const bool gradient : {false, true})
        for (const unsigned int threads : {1u, 2u})
          {
            const auto time = [&](const Function<2> &f) {
              const auto evaluate = [&](const std::size_t begin,
                                        const std::size_t end) {
                return gradient ? gradients(f, begin, end) :
                                  values(f, begin, end);
              };
              return best_of_five([&]() {
                if (threads == 1)
                  return evaluate(0, n);
                // the second thread takes the second half of the lists
                const std::size_t   half      = n / list_size / 2 * list_size;
                double              other_sum = 0;
                Threads::Task<void> other =
                  Threads::new_task([&]() { other_sum = evaluate(half, n); });
                const double sum = evaluate(0, half);
                other.join();
                return sum + other_sum;
              });
            };
            const auto [reference, reference_sum] = time(
              gradient ? static_cast<const Function<2> &>(parser_u) : parser_f);
            const auto [ours, our_sum] =
              time(gradient ? expression_u : expression_f);
            same = same && reference_sum == our_sum;
            std::cout << "| " << (gradient ? "gradients of " : "values of ")
                      << (gradient ? (e.u1.empty() ? "f1" : "u1") : "f1")
                      << " | " << threads << " | " << std::setprecision(3)
                      << reference << " | " << ours << " | "
                      << std::setprecision(2) << reference / ours << " |\n";
          }
      if (!same)
        throw std::runtime_error("the two gave different numbers");
      std::cout << "\nBoth gave the same sums to the last bit.\n";
    }
  catch (const std::exception &e)
    {
      std::cerr << "bench_expression_evaluation: " << e.what() << std::endl;
      return 1;
    }
}
