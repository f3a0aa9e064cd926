/// \file theory.hpp
/// \brief What kinetic theory says of a 2D hard-disk gas in equilibrium: the contact value of the
/// pair correlation (Henderson's equation of state) and the Enskog collision rate. Stage 07's
/// tests and `plab accuracy` compare the exact simulation with these.
#pragma once

#include <cmath>

namespace plab::theory {

/// Area fraction \f$ \eta = n \pi r^2 \f$ of disks of radius `r` at number density `n`.
inline double area_fraction(double n, double r) { return n * M_PI * r * r; }

/// Henderson's equation of state for hard disks,
/// \f$ Z = P/(nkT) = (1 + \eta^2/8)/(1 - \eta)^2 \f$ (accurate to a fraction of a percent up to
/// \f$ \eta \approx 0.5 \f$).
inline double henderson_z(double eta) { return (1 + eta * eta / 8) / ((1 - eta) * (1 - eta)); }

/// The pair correlation at contact that goes with it: in 2D \f$ Z = 1 + 2\eta\, g(\sigma) \f$, so
/// \f$ g(\sigma) = (1 - 7\eta/16)/(1 - \eta)^2 \f$.
inline double henderson_contact(double eta) { return (1 - 7 * eta / 16) / ((1 - eta) * (1 - eta)); }

/// Enskog's collision rate per particle of a 2D hard-disk gas (diameter \f$ \sigma = 2r \f$, unit
/// masses, \f$ kT = \langle v^2 \rangle / 2 \f$):
/// \f$ \omega = 2 \sigma n\, g(\sigma) \sqrt{\pi kT} \f$: the rate of a dilute gas, \f$ n \f$ times
/// the swept width \f$ 2\sigma \f$ times the mean relative speed \f$ \sqrt{\pi kT} \f$, raised by
/// the contact value \f$ g(\sigma) \f$. Each collision involves two particles, so the gas has
/// \f$ N\omega/2 \f$ collisions per unit time.
/// \param n  number density (particles per unit area)
/// \param r  disk radius
/// \param kT temperature (mean kinetic energy per particle, unit masses)
inline double enskog_rate(double n, double r, double kT) {
  const double sigma = 2 * r;
  return 2 * sigma * n * henderson_contact(area_fraction(n, r)) * std::sqrt(M_PI * kT);
}

}  // namespace plab::theory
