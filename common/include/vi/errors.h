#pragma once

#include <stdexcept>
#include <string>

namespace VI
{
  /**
   * Bad input: a parameter that is missing, out of range or inconsistent, a
   * malformed expression, an unreadable file or an output directory that
   * cannot be written. The programs end with the message on one line and
   * exit status 1 (see run_program()).
   */
  class InputError : public std::runtime_error
  {
  public:
    using std::runtime_error::runtime_error;
  };

  /**
   * A solver that did not deliver what it was asked for (iteration limit,
   * NaN, failed line search, breakdown of the linear solver). The message
   * says which solver failed and why; the programs end with exit status 2
   * and never report the unconverged iterate as a result.
   */
  class SolverFailure : public std::runtime_error
  {
  public:
    using std::runtime_error::runtime_error;
  };
} // namespace VI
