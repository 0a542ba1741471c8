#include <deal.II/base/config.h>
#include <deal.II/base/multithread_info.h>

#include <vi/errors.h>
#include <vi/process_usage.h>
#include <vi/summary.h>
#include <vi/version.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <iomanip>
#include <sstream>

namespace VI
{
  Json::Json()
      : value(nullptr)
  {
  }

  Json::Json(const double v)
      : value(v)
  {
  }

  Json::Json(const int v)
      : value(std::int64_t(v))
  {
  }

  Json::Json(const unsigned int v)
      : value(std::int64_t(v))
  {
  }

  Json::Json(const long v)
      : value(std::int64_t(v))
  {
  }

  Json::Json(const unsigned long v)
      : value(std::int64_t(v))
  {
  }

  Json::Json(const long long v)
      : value(std::int64_t(v))
  {
  }

  Json::Json(const unsigned long long v)
      : value(std::int64_t(v))
  {
  }

  Json::Json(const bool v)
      : value(v)
  {
  }

  Json::Json(const char *v)
      : value(std::string(v))
  {
  }

  Json::Json(const std::string &v)
      : value(v)
  {
  }


  Json
  Json::object()
  {
    Json json;
    json.value = Object();
    return json;
  }


  Json
  Json::object(std::initializer_list<std::pair<std::string, Json>> members)
  {
    Json json  = object();
    json.value = Object(members);
    return json;
  }


  Json
  Json::array()
  {
    Json json;
    json.value = Array();
    return json;
  }


  Json
  Json::raw(const std::string &json_text)
  {
    Json json;
    json.value = Raw{json_text};
    return json;
  }


  Json &
  Json::operator[](const std::string &key)
  {
    if (std::holds_alternative<std::nullptr_t>(value))
      value = Object();
    auto &members = std::get<Object>(value);
    for (auto &member : members)
      if (member.first == key)
        return member.second;
    members.emplace_back(key, Json());
    return members.back().second;
  }


  void
  Json::push_back(const Json &element)
  {
    if (std::holds_alternative<std::nullptr_t>(value))
      value = Array();
    std::get<Array>(value).push_back(element);
  }


  std::size_t
  Json::size() const
  {
    if (const auto *a = std::get_if<Array>(&value))
      return a->size();
    if (const auto *o = std::get_if<Object>(&value))
      return o->size();
    return 0;
  }


  namespace
  {
    void
    write_string(std::ostream &out, const std::string &s)
    {
      out << '"';
      for (const char c : s)
        switch (c)
          {
            case '"':
              out << "\\\"";
              break;
            case '\\':
              out << "\\\\";
              break;
            case '\n':
              out << "\\n";
              break;
            case '\t':
              out << "\\t";
              break;
            default:
              if (static_cast<unsigned char>(c) < 0x20)
                out << "\\u" << std::hex << std::setw(4) << std::setfill('0')
                    << int(c) << std::dec << std::setfill(' ');
              else
                out << c;
          }
      out << '"';
    }
  } // namespace


  void
  Json::write(std::ostream &out, const unsigned int indent) const
  {
    const std::string pad(indent + 2, ' '), end_pad(indent, ' ');
    if (std::holds_alternative<std::nullptr_t>(value))
      out << "null";
    else if (const auto *d = std::get_if<double>(&value))
      {
        if (std::isfinite(*d))
          {
            std::ostringstream number;
            number << std::setprecision(10) << *d;
            out << number.str();
          }
        else
          out << "null";
      }
    else if (const auto *i = std::get_if<std::int64_t>(&value))
      out << *i;
    else if (const auto *b = std::get_if<bool>(&value))
      out << (*b ? "true" : "false");
    else if (const auto *s = std::get_if<std::string>(&value))
      write_string(out, *s);
    else if (const auto *r = std::get_if<Raw>(&value))
      out << r->text;
    else if (const auto *a = std::get_if<Array>(&value))
      {
        // Arrays of numbers on one line, arrays of objects one per line.
        const bool flat =
          std::none_of(a->begin(), a->end(), [](const Json &element) {
            return std::holds_alternative<Object>(element.value) ||
                   std::holds_alternative<Array>(element.value);
          });
        out << '[';
        for (std::size_t n = 0; n < a->size(); ++n)
          {
            out << (n ? "," : "");
            if (flat)
              out << (n ? " " : "");
            else
              out << '\n' << pad;
            (*a)[n].write(out, indent + 2);
          }
        if (!flat && !a->empty())
          out << '\n' << end_pad;
        out << ']';
      }
    else if (const auto *o = std::get_if<Object>(&value))
      {
        out << '{';
        for (std::size_t n = 0; n < o->size(); ++n)
          {
            out << (n ? ",\n" : "\n") << pad;
            write_string(out, (*o)[n].first);
            out << ": ";
            (*o)[n].second.write(out, indent + 2);
          }
        if (!o->empty())
          out << '\n' << end_pad;
        out << '}';
      }
  }


  Json
  make_summary(const std::string        &program,
               const MPI_Comm            comm,
               dealii::ParameterHandler &prm)
  {
    Json summary                = Json::object();
    summary["program"]          = program;
    summary["version"]          = std::string(VI_VERSION);
    summary["git"]              = std::string(VI_GIT_REVISION);
    summary["deal_ii"]          = std::string(DEAL_II_PACKAGE_VERSION);
    summary["mpi_ranks"]        = dealii::Utilities::MPI::n_mpi_processes(comm);
    summary["threads_per_rank"] = dealii::MultithreadInfo::n_threads();
    std::ostringstream parameters;
    prm.print_parameters(parameters, dealii::ParameterHandler::ShortJSON);
    summary["parameters"] = Json::raw(parameters.str());
    return summary;
  }


  Json
  newton_steps(const NewtonReport &report)
  {
    Json steps = Json::array();
    for (const NewtonStep &step : report.steps)
      {
        Json it                        = Json::object();
        it["k"]                        = step.iteration;
        it["linear_iterations"]        = step.linear_iterations;
        it["residual_equations"]       = step.residual.equations;
        it["residual_complementarity"] = step.residual.complementarity;
        it["step_length"]              = step.step_length;
        if (step.smoothing > 0) // a step of the continuation
          it["smoothing"] = step.smoothing;
        if (step.has_active_set)
          {
            it["active_rows"] = step.active_set.active;
            if (step.iteration > 1)
              it["switched_rows"] = step.active_set.switched;
          }
        steps.push_back(it);
      }
    return steps;
  }


  Json
  to_json(const ProcessUsage &usage)
  {
    return Json::object({{"user_seconds", usage.user_seconds},
                         {"system_seconds", usage.system_seconds},
                         {"minor_page_faults", usage.minor_faults}});
  }


  void
  write_summary(const Json        &summary,
                const std::string &directory,
                const MPI_Comm     comm)
  {
    if (dealii::Utilities::MPI::this_mpi_process(comm) != 0)
      return;
    const std::string file_name = directory + "/summary.json";
    std::ofstream     out(file_name);
    summary.write(out);
    out << '\n';
    if (!out)
      throw InputError("cannot write " + file_name);
  }
} // namespace VI
