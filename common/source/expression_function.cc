#include <vi/errors.h>
#include <vi/expression_function.h>

#include <cmath>
#include <muParser.h>

namespace VI
{
  using namespace dealii;

  namespace
  {
    /// deal.II's FunctionParser rounds a condition to an integer.
    double
    round_to_int(const double x)
    {
      return static_cast<int>(x + (x >= 0 ? 0.5 : -0.5));
    }

    /// muparser's diagnosis on one line, with the place in the formula
    /// when the message does not give it.
    std::string
    diagnosis(const mu::Parser::exception_type &e)
    {
      std::string message  = e.GetMsg();
      const int   position = static_cast<int>(e.GetPos());
      if (message.find("position") == std::string::npos && position >= 0)
        message += position < static_cast<int>(e.GetExpr().size()) - 1 ?
                     " (at position " + std::to_string(position) + ")" :
                     " (at the end of the formula)";
      return message;
    }
  } // namespace


  template <int dim>
  struct ExpressionFunction<dim>::Evaluator
  {
    mu::Parser parser;
    /// x, y, z up to dim, then t.
    double variables[dim + 1] = {};
  };


  template <int dim>
  ExpressionFunction<dim>::ExpressionFunction(
    const std::string                   &formula,
    const std::map<std::string, double> &constants,
    const Point<dim>                    &probe,
    const bool                           time_dependent,
    const double                         h)
      : formula(formula)
      , constants(constants)
      , time_dependent(time_dependent)
      , h(h)
  {
    // Compiled and evaluated once here: a bad formula is reported now, not
    // on the first point of a worker thread.
    try
      {
        evaluate(evaluator(), probe);
      }
    catch (const mu::Parser::exception_type &e)
      {
        throw InputError(diagnosis(e));
      }
  }


  template <int dim>
  ExpressionFunction<dim>::~ExpressionFunction() = default;


  template <int dim>
  typename ExpressionFunction<dim>::Evaluator &
  ExpressionFunction<dim>::evaluator() const
  {
    std::unique_ptr<Evaluator> &e = evaluators.get();
    if (!e)
      {
        auto        fresh    = std::make_unique<Evaluator>();
        mu::Parser &parser   = fresh->parser;
        const char *names[3] = {"x", "y", "z"};
        for (unsigned int d = 0; d < dim; ++d)
          parser.DefineVar(names[d], &fresh->variables[d]);
        if (time_dependent)
          parser.DefineVar("t", &fresh->variables[dim]);
        for (const auto &[name, number] : constants)
          parser.DefineConst(name, number);
        // The functions deal.II's FunctionParser defines beyond muparser's,
        // with its meanings (a condition holds when it rounds to a nonzero
        // integer; log is the natural logarithm).
        parser.DefineFun(
          "if", +[](const double condition, const double a, const double b) {
            return round_to_int(condition) != 0 ? a : b;
          });
        parser.DefineFun("int", round_to_int);
        parser.DefineFun(
          "ceil", +[](const double x) { return std::ceil(x); });
        parser.DefineFun(
          "floor", +[](const double x) { return std::floor(x); });
        parser.DefineFun(
          "cot", +[](const double x) { return 1. / std::tan(x); });
        parser.DefineFun(
          "csc", +[](const double x) { return 1. / std::sin(x); });
        parser.DefineFun(
          "sec", +[](const double x) { return 1. / std::cos(x); });
        parser.DefineFun(
          "log", +[](const double x) { return std::log(x); });
        parser.DefineFun(
          "pow",
          +[](const double a, const double b) { return std::pow(a, b); });
        parser.DefineFun(
          "erf", +[](const double x) { return std::erf(x); });
        parser.DefineFun(
          "erfc", +[](const double x) { return std::erfc(x); });
        parser.SetExpr(formula);
        e = std::move(fresh);
      }
    return *e;
  }


  template <int dim>
  inline double
  ExpressionFunction<dim>::evaluate(Evaluator &e, const Point<dim> &p) const
  {
    for (unsigned int d = 0; d < dim; ++d)
      e.variables[d] = p[d];
    e.variables[dim] = this->get_time();
    return e.parser.Eval();
  }


  template <int dim>
  inline Tensor<1, dim>
  ExpressionFunction<dim>::differences(Evaluator        &e,
                                       const Point<dim> &p,
                                       const double      step,
                                       Tensor<1, dim>   *second_order) const
  {
    Tensor<1, dim> gradient;
    for (unsigned int i = 0; i < dim; ++i)
      {
        Tensor<1, dim> shift;
        shift[i]              = step;
        const Point<dim> near = p + shift, far = near + shift;
        const Point<dim> near_below = p - shift, far_below = near_below - shift;
        const double     f_far = evaluate(e, far), f_near = evaluate(e, near);
        const double     f_near_below = evaluate(e, near_below),
                     f_far_below      = evaluate(e, far_below);
        gradient[i] =
          (-f_far + 8 * f_near - 8 * f_near_below + f_far_below) / (12 * step);
        if (second_order)
          (*second_order)[i] = (f_near - f_near_below) / (2 * step);
      }
    return gradient;
  }


  // The differences of step h, checked against the second-order ones of
  // the same values, then against those of step h/4: where either agrees
  // to 1e-6 (smooth functions: to about 1e-9 and 1e-11) the result is that
  // of step h. Within a few h of a singularity of the formula (the corner
  // of the L-shape, at a distance below h on refined meshes) the stencil
  // straddles it and they do not: the step shrinks by 4 until two
  // successive steps agree, at most to h / 4^8. If they never do (a jump),
  // the function has no gradient there and the result is that of step h.
  template <int dim>
  inline Tensor<1, dim>
  ExpressionFunction<dim>::differentiate(Evaluator        &e,
                                         const Point<dim> &p) const
  {
    const auto agree = [](const Tensor<1, dim> &a, const Tensor<1, dim> &b) {
      return (a - b).norm() <= 1e-6 * (a.norm() + 1.);
    };
    Tensor<1, dim>       second_order;
    const Tensor<1, dim> at_h = differences(e, p, h, &second_order);
    if (agree(at_h, second_order))
      return at_h;
    double         step     = h / 4;
    Tensor<1, dim> gradient = differences(e, p, step);
    if (agree(at_h, gradient))
      return at_h;
    for (unsigned int k = 0; k < 7; ++k)
      {
        const Tensor<1, dim> finer = differences(e, p, step / 4);
        if (agree(gradient, finer))
          return gradient;
        gradient = finer;
        step /= 4;
      }
    return at_h;
  }


  template <int dim>
  double
  ExpressionFunction<dim>::value(const Point<dim> &p, const unsigned int) const
  {
    return evaluate(evaluator(), p);
  }


  template <int dim>
  void
  ExpressionFunction<dim>::value_list(const std::vector<Point<dim>> &points,
                                      std::vector<double>           &values,
                                      const unsigned int) const
  {
    AssertDimension(points.size(), values.size());
    Evaluator &e = evaluator();
    for (std::size_t q = 0; q < points.size(); ++q)
      values[q] = evaluate(e, points[q]);
  }


  template <int dim>
  Tensor<1, dim>
  ExpressionFunction<dim>::gradient(const Point<dim> &p,
                                    const unsigned int) const
  {
    return differentiate(evaluator(), p);
  }


  template <int dim>
  void
  ExpressionFunction<dim>::gradient_list(const std::vector<Point<dim>> &points,
                                         std::vector<Tensor<1, dim>> &gradients,
                                         const unsigned int) const
  {
    AssertDimension(points.size(), gradients.size());
    Evaluator &e = evaluator();
    for (std::size_t q = 0; q < points.size(); ++q)
      gradients[q] = differentiate(e, points[q]);
  }


  template <int dim>
  double
  ExpressionFunction<dim>::laplacian(const Point<dim> &p,
                                     const unsigned int) const
  {
    Evaluator   &e      = evaluator();
    const double centre = evaluate(e, p);
    double       sum    = 0;
    for (unsigned int i = 0; i < dim; ++i)
      {
        Tensor<1, dim> step;
        step[i]               = h;
        const Point<dim> near = p + step, far = near + step;
        const Point<dim> near_below = p - step, far_below = near_below - step;
        sum += (-evaluate(e, far) + 16 * evaluate(e, near) - 30 * centre +
                16 * evaluate(e, near_below) - evaluate(e, far_below)) /
               (12 * h * h);
      }
    return sum;
  }


  template class ExpressionFunction<1>;
  template class ExpressionFunction<2>;
} // namespace VI
