#pragma once

#include <deal.II/base/mpi.h>
#include <deal.II/base/parameter_handler.h>

#include <vi/semismooth_newton.h>

#include <cstdint>
#include <initializer_list>
#include <ostream>
#include <string>
#include <utility>
#include <variant>
#include <vector>

namespace VI
{
  struct ProcessUsage;

  /**
   * A JSON value, just enough to write summary.json: numbers (non-finite
   * ones as null), integers, strings, booleans, arrays and objects that keep
   * their keys in insertion order. Writing only; the summaries are read back
   * by Python in bench/.
   */
  class Json
  {
  public:
    Json(); ///< null
    Json(const double value);
    Json(const int value);
    Json(const unsigned int value);
    Json(const long value);
    Json(const unsigned long value);
    Json(const long long value);
    Json(const unsigned long long value);
    Json(const bool value);
    Json(const char *value);
    Json(const std::string &value);

    static Json
    object();
    /// An object with these members, in this order.
    static Json
    object(std::initializer_list<std::pair<std::string, Json>> members);
    static Json
    array();
    /// Text that is already JSON (e.g. ParameterHandler's output).
    static Json
    raw(const std::string &json_text);

    /// Object member, created (null) if absent.
    Json &
    operator[](const std::string &key);
    /// Append to an array.
    void
    push_back(const Json &value);

    std::size_t
    size() const;

    void
    write(std::ostream &out, const unsigned int indent = 0) const;

  private:
    struct Raw
    {
      std::string text;
    };
    using Array  = std::vector<Json>;
    using Object = std::vector<std::pair<std::string, Json>>;
    std::variant<std::nullptr_t,
                 double,
                 std::int64_t,
                 bool,
                 std::string,
                 Raw,
                 Array,
                 Object>
      value;
  };


  /**
   * The common head of summary.json: program, version, mpi_ranks, threads
   * and the parameters as read (ParameterHandler's JSON).
   */
  Json
  make_summary(const std::string        &program,
               const MPI_Comm            comm,
               dealii::ParameterHandler &prm);

  /**
   * The "newton_steps" list of a cycle or time step: per step k its
   * linear_iterations, residual_equations, residual_complementarity,
   * step_length and, where the problem reports its active sets,
   * active_rows and (from k = 2 on) switched_rows.
   */
  Json
  newton_steps(const NewtonReport &report);

  /// CPU seconds (user, system) and minor page faults of a span.
  Json
  to_json(const ProcessUsage &usage);

  /// Write `summary` to directory/summary.json on rank 0.
  void
  write_summary(const Json        &summary,
                const std::string &directory,
                const MPI_Comm     comm);
} // namespace VI
