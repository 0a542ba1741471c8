// GoogleTest driver of the unit tests: MPI (and with it Trilinos) is
// initialised once for all tests, which then run on MPI_COMM_WORLD.
#include <deal.II/base/mpi.h>

#include <gtest/gtest.h>

int
main(int argc, char **argv)
{
  dealii::Utilities::MPI::MPI_InitFinalize mpi(argc, argv, 1);
  ::testing::InitGoogleTest(&argc, argv);
  return RUN_ALL_TESTS();
}
