#pragma once

namespace VI
{
  /**
   * The tension of the gap w = u1 - u2, mu_r = mu1 mu2 / (mu1 + mu2): with
   * the mean m = (mu1 u1 + mu2 u2) / (mu1 + mu2), mu1 |grad u1|^2 +
   * mu2 |grad u2|^2 = (mu1 + mu2) |grad m|^2 + mu_r |grad w|^2, so the
   * contact acts on a membrane of tension mu_r.
   */
  constexpr double
  reduced_tension(const double mu1, const double mu2)
  {
    return mu1 * mu2 / (mu1 + mu2);
  }
} // namespace VI
