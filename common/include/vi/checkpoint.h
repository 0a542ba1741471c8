#pragma once

#include <deal.II/base/parameter_handler.h>

#include <functional>
#include <iosfwd>
#include <istream>
#include <optional>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

/**
 * The pieces of the text checkpoints that step-parabolic and step-twophase
 * share. A checkpoint starts with a head line ("step-x checkpoint, format
 * 1") and the problem it belongs to, then "keyword value" entries; doubles
 * are written with 17 significant digits, which read back to the same bits.
 */
namespace VI::Checkpoint
{
  /**
   * The parameters of the top-level `sections` of `prm` (those that define
   * the problem) as "Section/.../Name = value" lines: a checkpoint continues
   * only the problem it was written for, while solvers, time stepping and
   * output may change on resume.
   */
  std::vector<std::string>
  problem_fingerprint(const dealii::ParameterHandler &prm,
                      const std::vector<std::string> &sections);

  /// Write the head line and "problem n" followed by the n lines.
  void
  write_head(std::ostream                   &out,
             const std::string              &head,
             const std::vector<std::string> &problem);

  /// Read what write_head() wrote (a std::runtime_error whose text is
  /// `wrong_head` if the first line is not `head`) and compare the problem
  /// with `here`: the first line in which they differ, as (line there, line
  /// here) with `none` for a missing line, or nothing if they are the same.
  std::optional<std::pair<std::string, std::string>>
  read_head(std::istream                   &in,
            const std::string              &head,
            const std::string              &wrong_head,
            const std::vector<std::string> &here,
            const std::string              &none);

  /**
   * Call `write` on a stream to `file`.tmp (doubles to 17 digits), close it
   * with the line "end" and rename it to `file`: a crash while writing
   * leaves the previous checkpoint intact. Throws InputError if the stream
   * fails.
   */
  void
  write_atomically(const std::string                         &file,
                   const std::function<void(std::ostream &)> &write);

  /// Reads "keyword value" and checks the keyword.
  template <typename T>
  void
  read_entry(std::istream &in, const std::string &keyword, T &value)
  {
    std::string word;
    in >> word >> value;
    if (!in || word != keyword)
      throw std::runtime_error("expected <" + keyword + ">");
  }

  /// Reads the closing "end"; `truncated` is the text of the error.
  void
  read_end(std::istream &in, const std::string &truncated);
} // namespace VI::Checkpoint
