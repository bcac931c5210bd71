#include "interface/contact/hunt_crossley.h"

#include <algorithm>
#include <cmath>

namespace cosim::interface {

HuntCrossleyForce EvaluateHuntCrossley(const HuntCrossleyLaw& law, double impact_speed, double delta, double rate) {
  HuntCrossleyForce out;
  if (delta <= 0.0) return out;
  const double chi = 8.0 * (1.0 - law.restitution) / (5.0 * law.restitution);  // Eq. (8)
  const double v0 = std::max(impact_speed, law.speed_threshold);
  const double elastic = law.stiffness * std::pow(delta, law.exponent);
  const double factor = 1.0 + chi * rate / v0;
  out.f = elastic * factor;
  if (out.f <= 0.0) return HuntCrossleyForce{};  // separating faster than the law can pull: no force
  out.df_ddelta = law.exponent * law.stiffness * std::pow(delta, law.exponent - 1.0) * factor;
  out.df_drate = elastic * chi / v0;
  return out;
}

double EffectiveRestitution(double e, double exponent) {
  if (e >= 1.0) return 1.0;
  // m = K = δ̇⁻ = 1: δ̈ = −δⁿ (1 + χ δ̇), from δ = 0, δ̇ = 1, until δ returns to 0. The contact
  // lasts a time of order 1 (3.2 for n = 3/2, undamped): h = 2e-3 resolves it.
  const double chi = 8.0 * (1.0 - e) / (5.0 * e);
  auto accel = [&](double d, double v) {
    return d > 0.0 ? -std::pow(d, exponent) * std::max(0.0, 1.0 + chi * v) : 0.0;
  };
  double d = 0.0, v = 1.0;
  const double h = 2e-3;
  for (int i = 0; i < 1000000; ++i) {
    const double k1d = v, k1v = accel(d, v);
    const double k2d = v + 0.5 * h * k1v, k2v = accel(d + 0.5 * h * k1d, v + 0.5 * h * k1v);
    const double k3d = v + 0.5 * h * k2v, k3v = accel(d + 0.5 * h * k2d, v + 0.5 * h * k2v);
    const double k4d = v + h * k3v, k4v = accel(d + h * k3d, v + h * k3v);
    const double dn = d + h / 6.0 * (k1d + 2.0 * k2d + 2.0 * k3d + k4d);
    const double vn = v + h / 6.0 * (k1v + 2.0 * k2v + 2.0 * k3v + k4v);
    if (dn < 0.0) {
      // Back to δ = 0 inside this step: the speed there, by linear interpolation in δ.
      const double s = d / (d - dn);
      return -(v + s * (vn - v));
    }
    d = dn;
    v = vn;
  }
  return 0.0;  // never came back (e → 0: all energy dissipated)
}

double LawRestitution(double effective, double exponent) {
  if (effective >= 1.0) return 1.0;
  double lo = 1e-6, hi = 1.0;
  for (int i = 0; i < 60; ++i) {
    const double mid = 0.5 * (lo + hi);
    (EffectiveRestitution(mid, exponent) < effective ? lo : hi) = mid;
  }
  return 0.5 * (lo + hi);
}

}  // namespace cosim::interface
