// The end of a run when p4est's support library aborts: one line, the
// reason, and the exit status of bad input for a failed allocation.
#include <vi/program.h>

#include <gtest/gtest.h>

#include <cstddef>
#include <p4est.h>
#include <sc.h>

namespace
{
  // What P4EST_ALLOC does when the system refuses the memory: libsc's
  // allocation, which aborts on a null pointer.
  void
  allocate_more_than_any_machine_has()
  {
    VI::report_libsc_aborts_in_one_line(MPI_COMM_WORLD);
    void *block = sc_malloc(p4est_package_id, std::size_t(1) << 62);
    sc_free(p4est_package_id, block);
  }
} // namespace


TEST(LibscAbort, FailedAllocationEndsInOneLineWithStatusOne)
{
  GTEST_FLAG_SET(death_test_style, "threadsafe");
  EXPECT_EXIT(allocate_more_than_any_machine_has(),
              testing::ExitedWithCode(1),
              "^Error: out of memory on rank 0 in p4est \\(Returned NULL "
              "from malloc\\): the run needs more than the machine gives; "
              "use a coarser mesh\n$");
}
