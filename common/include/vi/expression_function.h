#pragma once

#include <deal.II/base/function.h>
#include <deal.II/base/point.h>
#include <deal.II/base/tensor.h>
#include <deal.II/base/thread_local_storage.h>

#include <map>
#include <memory>
#include <string>
#include <vector>

namespace VI
{
  /**
   * A scalar function given by a muparser formula in x, y (x in 1D) and, if
   * time dependent, t (the time of Function::set_time()). The formula may
   * use named constants, the ternary `c ? a : b`, muparser's functions
   * (sin, ..., atan2, sqrt, exp, ln, log10, min, max, ...) and those
   * deal.II's FunctionParser adds (if, int, ceil, floor, cot, csc, sec, log,
   * pow, erf, erfc).
   *
   * Why not dealii::FunctionParser: it finds its per-thread parser through a
   * ThreadLocalStorage, whose read-write lock it takes at every evaluation,
   * and a gradient by differences takes eight. Here the lookup is done
   * once per call of value_list() or gradient_list(), for all points of a
   * cell. Safe to call from several threads at once: each thread compiles
   * its own parser on first use.
   *
   * Gradients are fourth-order central differences with step h,
   *   (-f(p + 2h e_i) + 8 f(p + h e_i) - 8 f(p - h e_i) + f(p - 2h e_i))
   *   / (12 h),
   * evaluated in the order of deal.II's AutoDerivativeFunction::FourthOrder,
   * so the values are those of FunctionParser with that formula where the
   * function is smooth. Near a singularity closer than 2h to a point (the
   * corner of the L-shape, on cells smaller than h) the stencil would
   * straddle it: there the step shrinks by 4 until the differences of two
   * successive steps agree to 1e-6, at most to h / 4^8 (where they never
   * do, a jump, the gradient is that of step h). Whether the stencil is
   * clear is first asked of its own values: where the second-order
   * differences (f(p + h e_i) - f(p - h e_i)) / (2 h) agree with it to
   * 1e-6 (on smooth functions they differ by h^2 / 6 times the third
   * derivative, about 1e-9; a kink within 2h makes them differ), the
   * gradient costs 4 dim evaluations instead of the 8 dim of the
   * comparison with step h / 4.
   *
   * A malformed formula or an unknown name throws InputError with
   * muparser's diagnosis (at construction: the formula is evaluated once at
   * `probe`).
   */
  template <int dim>
  class ExpressionFunction : public dealii::Function<dim>
  {
  public:
    ExpressionFunction(const std::string                   &formula,
                       const std::map<std::string, double> &constants,
                       const dealii::Point<dim>            &probe,
                       const bool                           time_dependent,
                       const double                         h);
    ExpressionFunction(const ExpressionFunction &) = delete;
    ExpressionFunction &
    operator=(const ExpressionFunction &) = delete;
    ~ExpressionFunction() override;

    double
    value(const dealii::Point<dim> &p,
          const unsigned int        component = 0) const override;
    void
    value_list(const std::vector<dealii::Point<dim>> &points,
               std::vector<double>                   &values,
               const unsigned int component = 0) const override;
    dealii::Tensor<1, dim>
    gradient(const dealii::Point<dim> &p,
             const unsigned int        component = 0) const override;
    void
    gradient_list(const std::vector<dealii::Point<dim>> &points,
                  std::vector<dealii::Tensor<1, dim>>   &gradients,
                  const unsigned int component = 0) const override;
    /// Fourth-order central second differences with step h, summed over
    /// the directions (error about 3 eps |f| / h^2 from rounding).
    double
    laplacian(const dealii::Point<dim> &p,
              const unsigned int        component = 0) const override;

  private:
    /// One thread's compiled parser and the variables it reads.
    struct Evaluator;

    /// This thread's evaluator, compiled on its first call.
    Evaluator &
    evaluator() const;
    double
    evaluate(Evaluator &e, const dealii::Point<dim> &p) const;
    /// Fourth-order differences of the given step; `second_order`, if
    /// given, gets the second-order ones of the same values.
    dealii::Tensor<1, dim>
    differences(Evaluator                &e,
                const dealii::Point<dim> &p,
                double                    step,
                dealii::Tensor<1, dim>   *second_order = nullptr) const;
    /// The gradient: differences of step h, or smaller near a singularity.
    dealii::Tensor<1, dim>
    differentiate(Evaluator &e, const dealii::Point<dim> &p) const;

    const std::string                   formula;
    const std::map<std::string, double> constants;
    const bool                          time_dependent;
    const double                        h;
    mutable dealii::Threads::ThreadLocalStorage<std::unique_ptr<Evaluator>>
      evaluators;
  };
} // namespace VI
