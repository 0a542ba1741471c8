#include <deal.II/base/mpi.h>

#include <vi/process_usage.h>

#include <sys/resource.h>

namespace VI
{
  namespace
  {
    double
    seconds(const timeval &t)
    {
      return t.tv_sec + 1e-6 * t.tv_usec;
    }
  } // namespace


  ProcessUsage
  ProcessUsage::now(const MPI_Comm comm)
  {
    rusage usage{};
    getrusage(RUSAGE_SELF, &usage);
    const double mine[3] = {seconds(usage.ru_utime),
                            seconds(usage.ru_stime),
                            static_cast<double>(usage.ru_minflt)};
    double       total[3];
    dealii::Utilities::MPI::sum(dealii::ArrayView<const double>(mine, 3),
                                comm,
                                dealii::ArrayView<double>(total, 3));
    return {total[0], total[1], total[2]};
  }


  ProcessUsage
  ProcessUsage::operator-(const ProcessUsage &earlier) const
  {
    return {user_seconds - earlier.user_seconds,
            system_seconds - earlier.system_seconds,
            minor_faults - earlier.minor_faults};
  }


  double
  peak_resident_bytes(const MPI_Comm comm)
  {
    rusage usage{};
    getrusage(RUSAGE_SELF, &usage);
    // (ru_maxrss in KiB on Linux)
    return dealii::Utilities::MPI::sum(1024. * usage.ru_maxrss, comm);
  }
} // namespace VI
