#pragma once

// The compositional water-hydrogen model of [BJ14, BDMV20]: constitutive
// laws (van Genuchten-Mualem, ideal gas, Henry's law), the amounts of the
// two components per unit volume, and the scales that make the discrete
// equations dimensionless. Header-only: the unit tests use it directly.
//
// Components c in {w (water), h (hydrogen)}, phases liquid and gas. Water
// does not evaporate; hydrogen is in the gas and dissolved in the liquid.
// Unknowns: liquid saturation S, liquid pressure P, molar fraction chi of
// dissolved hydrogen. Everything here is in SI units.

#include <algorithm>
#include <cmath>

namespace StepTwoPhase
{
  /// One year of the benchmark (365 days), the unit of every time in the
  /// .prm files and in the output.
  constexpr double seconds_per_year = 365. * 24. * 3600.;


  /// A value and its derivative with respect to the liquid saturation.
  struct SaturationFunction
  {
    double value      = 0.;
    double derivative = 0.;
  };


  /// The physical data of the porous medium and the fluids (SI units).
  struct PhysicalParameters
  {
    double porosity                   = 0.15;    // phi
    double permeability               = 5e-20;   // K, m^2
    double van_genuchten_pressure     = 2e6;     // P_r, Pa
    double van_genuchten_n            = 1.49;    // n; m = 1 - 1/n
    double residual_liquid_saturation = 0.4;     // S_lr
    double residual_gas_saturation    = 0.;      // S_gr
    double liquid_viscosity           = 1e-3;    // mu_l, Pa s
    double gas_viscosity              = 9e-6;    // mu_g, Pa s
    double water_density              = 1000.;   // rho_w, kg/m^3
    double water_molar_mass           = 1e-2;    // M_w, kg/mol
    double hydrogen_molar_mass        = 2e-3;    // M_h, kg/mol
    double henry_constant             = 7.65e-6; // H, mol/(Pa m^3)
    double diffusion_coefficient      = 3e-9;    // D, m^2/s
    double temperature                = 303.;    // T, K
    double gas_constant               = 8.314;   // R, J/(mol K)
    /// Width epsilon (in effective saturation) of the intervals next to
    /// S_e = 0 and S_e = 1 where the van Genuchten-Mualem laws, whose
    /// derivatives are infinite at S_e = 1, are replaced by linear pieces.
    double regularization = 1e-5;
  };


  /**
   * Constitutive laws and amounts of the components.
   *
   * Effective saturation S_e = (S - S_lr) / (1 - S_lr - S_gr), m = 1 - 1/n:
   *   P_cp(S) = P_r (S_e^(-1/m) - 1)^(1/n),
   *   k_rl(S) = sqrt(S_e) (1 - (1 - S_e^(1/m))^m)^2,
   *   k_rg(S) = sqrt(1 - S_e) (1 - S_e^(1/m))^(2m).
   * P_cp and k_rl have infinite slopes at S_e = 1 (full liquid saturation,
   * exactly where gas appears), and none of the three is defined beyond
   * [0, 1], where semismooth Newton iterates may go. On [1 - eps, 1] each
   * law is therefore replaced by the linear interpolant of its values at
   * 1 - eps and 1 (P_cp(1) = 0, k_rl(1) = 1, k_rg(1) = 0), on [0, eps] by
   * its tangent at eps; beyond S_e = 1, P_cp continues linearly and
   * k_rl = 1, k_rg = 0; below S_e = 0, k_rl = 0, k_rg = 1. The laws are
   * continuous and piecewise smooth, which is all semismooth Newton needs.
   *
   * Amounts (kg per m^3 of porous medium):
   *   l_w = phi rho_w S,
   *   l_h = phi [ S gamma_2 chi + (1 - S) gamma_3 P^g ],   P^g = P + P_cp(S),
   * with gamma_2 = M_h beta^l (dissolved hydrogen: chi moles per mole of
   * liquid, beta^l = rho_w / M_w moles of liquid per m^3) and
   * gamma_3 = M_h / (R T) (ideal gas). Henry's law at equilibrium reads
   * beta^l chi = H P^g (moles of dissolved hydrogen per m^3 of liquid).
   */
  class TwoPhaseModel
  {
  public:
    explicit TwoPhaseModel(const PhysicalParameters &parameters)
        : p(parameters)
        , m(1. - 1. / parameters.van_genuchten_n)
        , saturation_range(1. - parameters.residual_liquid_saturation -
                           parameters.residual_gas_saturation)
        , liquid_molar_density(parameters.water_density /
                               parameters.water_molar_mass)
        , dissolved_density(parameters.hydrogen_molar_mass *
                            liquid_molar_density)
        , gas_density_per_pressure(
            parameters.hydrogen_molar_mass /
            (parameters.gas_constant * parameters.temperature))
    {
    }

    const PhysicalParameters &
    parameters() const
    {
      return p;
    }

    /// beta^l = rho_w / M_w, mol/m^3.
    double
    beta_l() const
    {
      return liquid_molar_density;
    }

    /// gamma_2 = M_h beta^l: kg of dissolved hydrogen per m^3 of liquid and
    /// unit molar fraction.
    double
    gamma_2() const
    {
      return dissolved_density;
    }

    /// gamma_3 = M_h / (R T): hydrogen gas density per unit pressure.
    double
    gamma_3() const
    {
      return gas_density_per_pressure;
    }

    /// The molar fraction in equilibrium with gas at pressure P^g:
    /// chi = H P^g / beta^l.
    double
    equilibrium_molar_fraction(const double gas_pressure) const
    {
      return p.henry_constant * gas_pressure / liquid_molar_density;
    }

    double
    effective_saturation(const double S) const
    {
      return (S - p.residual_liquid_saturation) / saturation_range;
    }

    SaturationFunction
    capillary_pressure(const double S) const
    {
      return in_saturation(regularized(
        effective_saturation(S),
        [this](const double Se) { return van_genuchten(Se); },
        0.,
        Extension::linear));
    }

    SaturationFunction
    liquid_relative_permeability(const double S) const
    {
      return in_saturation(regularized(
        effective_saturation(S),
        [this](const double Se) { return mualem_liquid(Se); },
        1.,
        Extension::constant));
    }

    SaturationFunction
    gas_relative_permeability(const double S) const
    {
      return in_saturation(regularized(
        effective_saturation(S),
        [this](const double Se) { return mualem_gas(Se); },
        0.,
        Extension::constant));
    }

    /// l_w(S) = phi rho_w S (its derivative is the constant phi rho_w).
    double
    water_amount(const double S) const
    {
      return p.porosity * p.water_density * S;
    }

    /// l_h and its partial derivatives (d/dS, d/dP, d/dchi) for a given
    /// capillary pressure P_cp(S) (with its derivative).
    struct HydrogenAmount
    {
      double value = 0., d_S = 0., d_P = 0., d_chi = 0.;
    };

    HydrogenAmount
    hydrogen_amount(const double              S,
                    const double              P,
                    const double              chi,
                    const SaturationFunction &P_cp) const
    {
      const double phi = p.porosity, g2 = dissolved_density,
                   g3   = gas_density_per_pressure;
      const double   Pg = P + P_cp.value;
      HydrogenAmount l;
      l.value = phi * (S * g2 * chi + (1. - S) * g3 * Pg);
      l.d_S   = phi * (g2 * chi - g3 * Pg + (1. - S) * g3 * P_cp.derivative);
      l.d_P   = phi * (1. - S) * g3;
      l.d_chi = phi * S * g2;
      return l;
    }

  private:
    enum class Extension
    {
      linear,  ///< continue the last linear piece beyond S_e = 1
      constant ///< keep the value at S_e = 1
    };

    /// The law f on [eps, 1 - eps], linear pieces outside (see the class
    /// documentation); derivatives with respect to S_e.
    template <typename Law>
    SaturationFunction
    regularized(const double    Se,
                const Law      &f,
                const double    value_at_one,
                const Extension beyond_one) const
    {
      const double eps = p.regularization;
      if (Se > 1. - eps)
        {
          const double slope = (value_at_one - f(1. - eps).value) / eps;
          if (Se > 1. && beyond_one == Extension::constant)
            return {value_at_one, 0.};
          return {value_at_one + slope * (Se - 1.), slope};
        }
      if (Se < eps)
        {
          const SaturationFunction at_eps = f(eps);
          if (Se < 0. && beyond_one == Extension::constant)
            {
              // k_rl -> 0 and k_rg -> 1 at S_e = 0: continue by the
              // tangent down to S_e = 0, then constantly.
              const double at_zero = at_eps.value - at_eps.derivative * eps;
              return {at_zero, 0.};
            }
          return {at_eps.value + at_eps.derivative * (Se - eps),
                  at_eps.derivative};
        }
      return f(Se);
    }

    SaturationFunction
    in_saturation(const SaturationFunction &f) const
    {
      return {f.value, f.derivative / saturation_range};
    }

    // P_r (Se^(-1/m) - 1)^(1/n)
    SaturationFunction
    van_genuchten(const double Se) const
    {
      const double n = p.van_genuchten_n;
      const double a = std::pow(Se, -1. / m);    // Se^(-1/m)
      const double b = std::pow(a - 1., 1. / n); // (Se^(-1/m) - 1)^(1/n)
      return {p.van_genuchten_pressure * b,
              p.van_genuchten_pressure * b / (n * (a - 1.)) * (-a / (m * Se))};
    }

    // sqrt(Se) (1 - (1 - Se^(1/m))^m)^2
    SaturationFunction
    mualem_liquid(const double Se) const
    {
      const double s  = std::pow(Se, 1. / m); // Se^(1/m)
      const double c  = std::pow(1. - s, m);  // (1 - Se^(1/m))^m
      const double A  = 1. - c;
      const double r  = std::sqrt(Se);
      const double dA = c / (1. - s) * s / Se; // d/dSe of A
      return {r * A * A, 0.5 / r * A * A + 2. * r * A * dA};
    }

    // sqrt(1 - Se) (1 - Se^(1/m))^(2m)
    SaturationFunction
    mualem_gas(const double Se) const
    {
      const double s  = std::pow(Se, 1. / m);
      const double B  = std::pow(1. - s, 2. * m);
      const double r  = std::sqrt(1. - Se);
      const double dB = -2. * B / (1. - s) * s / Se; // d/dSe of B
      return {r * B, -0.5 / r * B + r * dB};
    }

    const PhysicalParameters p;
    const double             m;
    const double             saturation_range;
    const double             liquid_molar_density;
    const double             dissolved_density;
    const double             gas_density_per_pressure;
  };
} // namespace StepTwoPhase
