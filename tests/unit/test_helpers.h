// Checks shared by several unit tests.
#pragma once

#include <deal.II/lac/full_matrix.h>
#include <deal.II/lac/lapack_full_matrix.h>
#include <deal.II/lac/vector.h>

#include <gtest/gtest.h>

#include <string>

namespace VITest
{
  /// Fail unless `action` throws an `Error` whose message contains
  /// `fragment`: a failure must say what went wrong, not only that it did.
  template <typename Error, typename Action>
  void
  expect_error_saying(const std::string &fragment, const Action &action)
  {
    try
      {
        action();
        ADD_FAILURE() << "no error saying \"" << fragment << '"';
      }
    catch (const Error &error)
      {
        EXPECT_NE(std::string(error.what()).find(fragment), std::string::npos)
          << error.what();
      }
  }


  /// The eigenvalues of the symmetric matrix `A`, in increasing order
  /// (LAPACK), to test definiteness and the dimension of a kernel.
  inline dealii::Vector<double>
  symmetric_eigenvalues(const dealii::FullMatrix<double> &A)
  {
    dealii::LAPACKFullMatrix<double> A_lapack(A.m(), A.n());
    A_lapack = A;
    dealii::Vector<double>     eigenvalues;
    dealii::FullMatrix<double> eigenvectors;
    A_lapack.compute_eigenvalues_symmetric(
      -1e300, 1e300, 0., eigenvalues, eigenvectors);
    return eigenvalues;
  }
} // namespace VITest
