#pragma once

// What the conforming (estimators.cc) and the dG (dg_estimators.cc)
// contact estimators share on every cell: a private header of vi_common.

#include <deal.II/base/array_view.h>
#include <deal.II/base/mpi.h>

#include <vi/estimators.h>

#include <array>
#include <cmath>
#include <utility>

namespace VI
{
  // The global sums of an estimate, indexed by the estimator's enum class
  // Sum (its last entry n_sums): one array, so that the cell terms are
  // added up in one loop and reduced over the processes in one call.
  template <typename Sum>
  class EstimateSums
  {
  public:
    static constexpr unsigned int size = static_cast<unsigned int>(Sum::n_sums);

    double &
    operator[](const Sum sum)
    {
      return values[static_cast<unsigned int>(sum)];
    }

    double
    operator[](const Sum sum) const
    {
      return values[static_cast<unsigned int>(sum)];
    }

    // Of a pair of consecutive entries (first for membrane 1, the next for
    // membrane 2), the one of membrane a = 0, 1.
    double &
    of_membrane(const Sum first, const unsigned int a)
    {
      return values[static_cast<unsigned int>(first) + a];
    }

    double
    of_membrane(const Sum first, const unsigned int a) const
    {
      return values[static_cast<unsigned int>(first) + a];
    }

    void
    clear()
    {
      values.fill(0.);
    }

    EstimateSums &
    operator+=(const EstimateSums &other)
    {
      for (unsigned int k = 0; k < size; ++k)
        values[k] += other.values[k];
      return *this;
    }

    // The sums over the processes of comm (collective).
    EstimateSums
    sum_over_processes(const MPI_Comm comm) const
    {
      EstimateSums total;
      dealii::Utilities::MPI::sum(
        dealii::ArrayView<const double>(values.data(), size),
        comm,
        dealii::ArrayView<double>(total.values.data(), size));
      return total;
    }

  private:
    std::array<double, size> values{};
  };


  // The multiplier's sums of a cell of diameter h_K: with lambda_h = c_K
  // lambda_h^pos + delta (split_multiplier()), sum (h_K / pi)^2 |delta -
  // m_K|^2 (Poincare's inequality) and m_K^2 |K|, of lambda_h and of the
  // multiplier lambda~ of the nonnegative coefficients (the entries
  // multiplier_local, multiplier_mean, multiplier_local_disc and
  // multiplier_mean_disc of Sum). Returns both splits.
  template <typename Sum>
  std::pair<MultiplierSplit, MultiplierSplit>
  add_multiplier_sums(const std::vector<double> &lambda,
                      const std::vector<double> &lambda_nonnegative,
                      const std::vector<double> &JxW,
                      const double               h_K,
                      EstimateSums<Sum>         &cell)
  {
    const MultiplierSplit split = split_multiplier(lambda, JxW),
                          split_disc =
                            split_multiplier(lambda_nonnegative, JxW);
    const double poincare_squared = std::pow(h_K / dealii::numbers::PI, 2);
    cell[Sum::multiplier_local] = poincare_squared * split.oscillation_squared;
    cell[Sum::multiplier_mean]  = split.mean_squared;
    cell[Sum::multiplier_local_disc] =
      poincare_squared * split_disc.oscillation_squared;
    cell[Sum::multiplier_mean_disc] = split_disc.mean_squared;
    return {split, split_disc};
  }


  // The constants of both estimates: the tensions, the weight theta of the
  // cone reconstruction s~ = s + (theta w, -(1 - theta) w), and c_mu, C of
  // |grad(w1 - w2)|_K <= c_mu |||w|||_K and |w1 - w2| <= C |||w||| (w in
  // H^1_0, C_F Friedrichs' constant).
  struct MembraneConstants
  {
    // Over a rigid obstacle (mu2 -> infinity): theta = 1, c_mu = mu1^(-1/2).
    MembraneConstants(const double mu1,
                      const double mu2,
                      const double friedrichs_constant,
                      const bool   rigid_second = false)
        : mu{mu1, mu2}
        , theta(rigid_second ? 1. : mu2 / (mu1 + mu2))
        , c_mu(std::sqrt(1. / mu1 + (rigid_second ? 0. : 1. / mu2)))
        , C(friedrichs_constant * c_mu)
    {
    }

    const double mu[2];
    const double theta;
    const double c_mu;
    const double C;
  };


  // The shared data of both membranes as pairs, indexed by a = 0, 1 as the
  // cell loops and lift_boundary_data() take them.
  template <int dim>
  struct MembranePairs
  {
    explicit MembranePairs(const ContactEstimatorData<dim> &data)
        : u{data.u1, data.u2}
        , s{data.s1, data.s2}
        , f{data.f1, data.f2}
        , g{data.g1, data.g2}
    {
    }

    const dealii::TrilinosWrappers::MPI::Vector *u[2], *s[2];
    const dealii::Function<dim>                 *f[2], *g[2];
  };
} // namespace VI
