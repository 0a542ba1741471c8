#include <deal.II/base/config.h>
#include <deal.II/base/multithread_info.h>
#include <deal.II/base/utilities.h>

#include <vi/errors.h>
#include <vi/parameters.h>
#include <vi/program.h>
#include <vi/version.h>

#include <cstdio>
#include <cstring>
#include <dlfcn.h>
#include <filesystem>
#include <fstream>
#include <new>
#include <sc.h>
#if defined(__GLIBC__)
#  include <malloc.h>
#endif
#include <iostream>
#include <sstream>

namespace VI
{
  using namespace dealii;

  namespace
  {
    /// deal.II's exception text, reduced to one line.
    std::string
    one_line(const std::string &text)
    {
      std::string line;
      bool        space = false;
      for (const char c : text)
        if (std::isspace(static_cast<unsigned char>(c)))
          space = !line.empty();
        else
          {
            if (space)
              line += ' ';
            line += c;
            space = false;
          }
      return line;
    }


    std::string
    exception_info(const ExceptionBase &exception)
    {
      std::ostringstream info;
      exception.print_info(info);
      return one_line(info.str());
    }


    /**
     * "Section/Subsection/Name=value" -> the same as the lines
     * "subsection Section", "subsection Subsection", "set Name = value" and
     * the "end"s in the parameter file.
     */
    void
    apply_override(ParameterHandler &prm, const std::string &assignment)
    {
      const auto equal = assignment.find('=');
      if (equal == std::string::npos)
        throw InputError("--set " + assignment +
                         ": expected Section/Name=value");
      const std::vector<std::string> path =
        Utilities::split_string_list(assignment.substr(0, equal), '/');
      std::string text;
      for (std::size_t n = 0; n + 1 < path.size(); ++n)
        text += "subsection " + path[n] + "\n";
      text +=
        "set " + path.back() + " = " + assignment.substr(equal + 1) + "\n";
      for (std::size_t n = 0; n + 1 < path.size(); ++n)
        text += "end\n";
      try
        {
          prm.parse_input_from_string(text, "--set");
        }
      catch (const ExceptionBase &exception)
        {
          throw InputError("--set " + assignment + ": " +
                           exception_info(exception));
        }
    }


    void
    print_usage(const ProgramDescription &program)
    {
      std::cout
        << program.name << ": " << program.purpose << "\n\n"
        << "Usage: " << program.name
        << " [--help | --print-parameters | file.prm [--set "
           "Section/Name=value]...]\n\n"
        << "  file.prm            run the scene described by the parameter "
           "file\n"
        << "  --set Section/Name=value\n"
        << "                      override one parameter of the file, e.g.\n"
        << "                      --set \"Discretization/Polynomial "
           "degree=3\"\n"
        << "  --print-parameters  print every parameter with its default "
           "value and documentation\n"
        << "  --help              print this message\n\n"
        << "Parallel runs: mpirun -np N " << program.name << " file.prm\n"
        << "Exit status: 0 success, 1 bad input, 2 solver failure, 3 "
           "internal error.\n";
    }


    /**
     * OpenBLAS's sequential build (Debian's libopenblas0-serial) is not
     * safe to call from several threads at once, and deal.II's worker
     * threads call LAPACK concurrently (the local solves of step-hho):
     * with it, tests of step-hho failed on two threads and passed on one
     * (doc/performance.md, "The BLAS of the direct solver"). OpenBLAS
     * reports its threading model through openblas_get_parallel(), 0 for
     * the sequential build; other BLAS libraries do not have the symbol.
     * With that build, run on one thread per process and say so.
     */
    void
    avoid_concurrent_calls_to_sequential_openblas(const MPI_Comm comm)
    {
      using Query = int (*)();
      const auto query =
        reinterpret_cast<Query>(dlsym(RTLD_DEFAULT, "openblas_get_parallel"));
      if (query == nullptr || query() != 0 || MultithreadInfo::n_threads() == 1)
        return;
      MultithreadInfo::set_thread_limit(1);
      if (Utilities::MPI::this_mpi_process(comm) == 0)
        std::cerr << "Note: the BLAS is OpenBLAS's sequential build, which is "
                     "not safe to call from several threads; running on one "
                     "thread per process (libopenblas0-pthread allows more)"
                  << std::endl;
    }


    /**
     * p4est's support library (libsc) does not throw: when an allocation in
     * p4est fails, or one of its checks, it logs "Abort: <reason>" and calls
     * its abort handler, which by default calls MPI_Abort and abort() with
     * neither the reason (deal.II sets libsc's log to silent) nor a word on
     * what to change. These handlers keep the first such reason and turn
     * the abort into the one line and the exit status of a std::bad_alloc
     * (run_program()); any other reason is reported as an internal error.
     */
    char     libsc_abort_reason[256] = ""; // no allocation when memory is out
    MPI_Comm libsc_comm              = MPI_COMM_WORLD;

    void
    keep_libsc_abort_reason(FILE *,
                            const char *,
                            int,
                            int,
                            int,
                            int,
                            const char *message)
    {
      if (libsc_abort_reason[0] != '\0' ||
          std::strncmp(message, "Abort: ", 7) != 0)
        return;
      std::snprintf(libsc_abort_reason,
                    sizeof(libsc_abort_reason),
                    "%s",
                    message + 7);
      libsc_abort_reason[std::strcspn(libsc_abort_reason, "\n")] = '\0';
    }


    [[noreturn]] void
    end_libsc_abort_in_one_line()
    {
      int rank = 0, size = 1;
      MPI_Comm_rank(libsc_comm, &rank);
      MPI_Comm_size(libsc_comm, &size);
      const bool out_of_memory =
        std::strstr(libsc_abort_reason, "alloc") != nullptr;
      std::fprintf(stderr,
                   "%s on rank %d in p4est (%s)%s\n",
                   out_of_memory ? "Error: out of memory" : "Internal error",
                   rank,
                   libsc_abort_reason,
                   out_of_memory ? ": the run needs more than the machine "
                                   "gives; use a coarser mesh" :
                                   "");
      const int status = out_of_memory ? 1 : 3;
      if (size > 1)
        MPI_Abort(libsc_comm, status);
      std::_Exit(status);
    }


    int
    report(const MPI_Comm comm, const std::string &message, const int status)
    {
      if (Utilities::MPI::this_mpi_process(comm) == 0)
        std::cerr << message << std::endl;
      return status;
    }
  } // namespace


  void
  report_libsc_aborts_in_one_line(const MPI_Comm comm)
  {
    libsc_comm = comm;
    sc_set_log_defaults(nullptr, keep_libsc_abort_reason, SC_LP_ERROR);
    // deal.II calls sc_init() only for p4est before 2.0; without it libsc
    // logs as no package, at the default threshold set here.
    if (sc_package_id >= 0)
      sc_package_set_verbosity(sc_package_id, SC_LP_ERROR);
    sc_set_abort_handler(end_libsc_abort_in_one_line);
  }


  std::string
  run_header(const std::string &program, const MPI_Comm comm)
  {
    std::ostringstream header;
    header << program << " " << VI_VERSION << " (" << VI_GIT_REVISION
           << "), deal.II " << DEAL_II_PACKAGE_VERSION << ", "
           << Utilities::MPI::n_mpi_processes(comm) << " MPI rank(s) x "
           << MultithreadInfo::n_threads() << " thread(s)";
    return header.str();
  }


  void
  prepare_output_directory(const std::string &directory, const MPI_Comm comm)
  {
    std::string error;
    if (Utilities::MPI::this_mpi_process(comm) == 0)
      {
        try
          {
            std::filesystem::create_directories(directory);
            const std::string probe = directory + "/.write-test";
            std::ofstream     out(probe);
            out << "x";
            out.close();
            if (!out)
              error = "is not writable";
            std::filesystem::remove(probe);
          }
        catch (const std::filesystem::filesystem_error &e)
          {
            error = "cannot be created (" + e.code().message() + ")";
          }
      }
    error = Utilities::MPI::broadcast(comm, error, 0);
    if (!error.empty())
      throw InputError("Output/Directory <" + directory + "> " + error);
  }


  int
  run_program(int argc, char **argv, const ProgramDescription &program)
  {
#if defined(__GLIBC__)
    // No fastbins in glibc's allocator. The estimators free many small
    // blocks per vertex patch and allocate one of more than 1 kB per patch;
    // glibc consolidates all fastbin blocks before every such allocation,
    // which took 25 - 30 % of an adaptive run (disk, Q1, 1.2e4 - 5e4
    // unknowns per field; perf: malloc_consolidate, unlink_chunk).
    mallopt(M_MXFAST, 0);
#endif
    Utilities::MPI::MPI_InitFinalize mpi(argc, argv);
    const MPI_Comm                   comm = MPI_COMM_WORLD;
    avoid_concurrent_calls_to_sequential_openblas(comm);
    report_libsc_aborts_in_one_line(comm);

    ParameterHandler prm;
    program.declare_parameters(prm);

    const std::vector<std::string> arguments(argv + 1, argv + argc);
    if (arguments.size() == 1 &&
        (arguments[0] == "--help" || arguments[0] == "-h"))
      {
        if (Utilities::MPI::this_mpi_process(comm) == 0)
          print_usage(program);
        return 0;
      }
    if (arguments.size() == 1 && arguments[0] == "--print-parameters")
      {
        if (Utilities::MPI::this_mpi_process(comm) == 0)
          prm.print_parameters(std::cout, ParameterHandler::PRM);
        return 0;
      }
    if (arguments.empty() || arguments[0].rfind("-", 0) == 0)
      {
        if (Utilities::MPI::this_mpi_process(comm) == 0)
          print_usage(program);
        return report(comm, "Error: expected a parameter file (or --help)", 1);
      }

    const std::string &file = arguments[0];
    try
      {
        if (!std::ifstream(file))
          throw InputError("cannot open parameter file <" + file + ">");
        set_parameter_directory(
          std::filesystem::path(file).parent_path().string());
        try
          {
            prm.parse_input(file);
          }
        catch (const ExceptionBase &exception)
          {
            throw InputError("in " + file + ": " + exception_info(exception));
          }
        for (std::size_t a = 1; a < arguments.size(); a += 2)
          {
            if (arguments[a] != "--set" || a + 1 == arguments.size())
              throw InputError("unexpected argument <" + arguments[a] +
                               ">; after the parameter file only --set "
                               "Section/Name=value is accepted");
            apply_override(prm, arguments[a + 1]);
          }
        program.run(prm, comm);
      }
    catch (const InputError &e)
      {
        return report(comm, "Error: " + one_line(e.what()), 1);
      }
    catch (const SolverFailure &e)
      {
        return report(comm, "Solver failure: " + one_line(e.what()), 2);
      }
    catch (const std::bad_alloc &)
      {
        // An allocation the model of MemoryBudget did not foresee, maybe on
        // one rank only: it says so itself and ends the others too.
        std::cerr << "Error: out of memory on rank "
                  << Utilities::MPI::this_mpi_process(comm)
                  << ": the run needs more than the machine gives; use a "
                     "coarser mesh"
                  << std::endl;
        if (Utilities::MPI::n_mpi_processes(comm) > 1)
          MPI_Abort(comm, 1);
        return 1;
      }
    catch (const ExceptionBase &e)
      {
        std::cerr << "Internal error on rank "
                  << Utilities::MPI::this_mpi_process(comm) << ": "
                  << exception_info(e) << std::endl;
        if (Utilities::MPI::n_mpi_processes(comm) > 1)
          MPI_Abort(comm, 3);
        return 3;
      }
    catch (const std::exception &e)
      {
        std::cerr << "Internal error on rank "
                  << Utilities::MPI::this_mpi_process(comm) << ": "
                  << one_line(e.what()) << std::endl;
        if (Utilities::MPI::n_mpi_processes(comm) > 1)
          MPI_Abort(comm, 3);
        return 3;
      }
    return 0;
  }
} // namespace VI
