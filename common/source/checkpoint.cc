// The text format shared by the checkpoints of step-parabolic and
// step-twophase (see vi/checkpoint.h).

#include <vi/checkpoint.h>
#include <vi/errors.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <limits>
#include <sstream>

namespace VI::Checkpoint
{
  std::vector<std::string>
  problem_fingerprint(const dealii::ParameterHandler &prm,
                      const std::vector<std::string> &sections)
  {
    std::ostringstream text;
    prm.print_parameters(text,
                         dealii::ParameterHandler::PRM |
                           dealii::ParameterHandler::Short);
    std::istringstream       in(text.str());
    std::vector<std::string> path, lines;
    for (std::string line; std::getline(in, line);)
      {
        const auto first = line.find_first_not_of(' ');
        if (first == std::string::npos)
          continue;
        line = line.substr(first);
        if (line.rfind("subsection ", 0) == 0)
          path.push_back(line.substr(11));
        else if (line == "end")
          path.pop_back();
        else if (line.rfind("set ", 0) == 0 && !path.empty() &&
                 std::find(sections.begin(), sections.end(), path[0]) !=
                   sections.end())
          {
            std::string name;
            for (const std::string &section : path)
              name += section + "/";
            lines.push_back(name + line.substr(4));
          }
      }
    return lines;
  }


  void
  write_head(std::ostream                   &out,
             const std::string              &head,
             const std::vector<std::string> &problem)
  {
    out << head << '\n';
    out << "problem " << problem.size() << '\n';
    for (const std::string &line : problem)
      out << line << '\n';
  }


  std::optional<std::pair<std::string, std::string>>
  read_head(std::istream                   &in,
            const std::string              &head,
            const std::string              &wrong_head,
            const std::vector<std::string> &here,
            const std::string              &none)
  {
    std::string line;
    std::getline(in, line);
    if (line != head)
      throw std::runtime_error(wrong_head);
    std::size_t n = 0;
    read_entry(in, "problem", n);
    in.ignore(std::numeric_limits<std::streamsize>::max(), '\n');
    std::vector<std::string> there(n);
    for (std::string &l : there)
      std::getline(in, l);
    for (std::size_t k = 0; k < std::max(there.size(), here.size()); ++k)
      if (k >= there.size() || k >= here.size() || there[k] != here[k])
        return std::make_pair(k < there.size() ? there[k] : none,
                              k < here.size() ? here[k] : none);
    return std::nullopt;
  }


  void
  write_atomically(const std::string                         &file,
                   const std::function<void(std::ostream &)> &write)
  {
    const std::string temporary = file + ".tmp";
    {
      std::ofstream out(temporary);
      out << std::setprecision(std::numeric_limits<double>::max_digits10);
      write(out);
      out << "end\n";
      if (!out)
        throw InputError("cannot write " + temporary);
    }
    std::filesystem::rename(temporary, file);
  }


  void
  read_end(std::istream &in, const std::string &truncated)
  {
    std::string end;
    in >> end;
    if (!in || end != "end")
      throw std::runtime_error(truncated);
  }
} // namespace VI::Checkpoint
