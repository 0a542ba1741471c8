#pragma once

#include <optional>
#include <string>
#include <utility>
#include <vector>

namespace VI
{
  /**
   * The .prm spelling of each value of a choice (an enum), in the order the
   * documentation lists them: one table gives the parsing, the printing and
   * the accepted values of a parameter.
   */
  template <typename Enum>
  using Spellings = std::vector<std::pair<Enum, std::string>>;

  /// The value spelt `name`, if any.
  template <typename Enum>
  std::optional<Enum>
  value_spelt(const Spellings<Enum> &table, const std::string &name)
  {
    for (const auto &[value, spelling] : table)
      if (spelling == name)
        return value;
    return std::nullopt;
  }

  /// The spelling of `value` ("?" if the table lacks it).
  template <typename Enum>
  std::string
  spelling_of(const Spellings<Enum> &table, const Enum value)
  {
    for (const auto &[v, spelling] : table)
      if (v == value)
        return spelling;
    return "?";
  }

  /// All spellings separated by '|', as ParameterHandler patterns take them.
  template <typename Enum>
  std::string
  all_spellings(const Spellings<Enum> &table)
  {
    std::string names;
    for (const auto &[value, spelling] : table)
      names += (names.empty() ? "" : "|") + spelling;
    return names;
  }

  /**
   * A choice among the values of an enum that knows its .prm spelling: the
   * base of the classes built on one (ComplementarityFunction,
   * InteriorPenalty), whose static Derived::spellings() is the table.
   */
  template <typename Derived, typename Enum>
  class SpeltChoice
  {
  public:
    /// The accepted names, separated by '|', for ParameterHandler patterns.
    static std::string
    names()
    {
      return all_spellings(Derived::spellings());
    }

    Enum
    type() const
    {
      return type_;
    }

    /// The .prm spelling of the choice.
    std::string
    name() const
    {
      return spelling_of(Derived::spellings(), type_);
    }

  protected:
    explicit SpeltChoice(const Enum type)
        : type_(type)
    {
    }

    Enum type_;
  };
} // namespace VI
