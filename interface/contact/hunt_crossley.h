#pragma once
// The visco-elastic Hertzian contact law of Flores et al. (Hunt–Crossley dissipation written
// with a restitution coefficient; rotor-sailing paper Eq. (8)), shared by the smooth solver's
// continuous contacts and the penalty contact process:
//   f = K δⁿ (1 + 8(1 − e)/(5e) · δ̇/δ̇⁻) >= 0,
// δ > 0 the penetration, δ̇ its rate, δ̇⁻ the approach speed when the contact began (at least
// `speed_threshold`).
//
// The law's e is not the coefficient of restitution the law produces: integrating the contact
// ODE m δ̈ = −f from δ̇ = δ̇⁻ gives a rebound e_eff(e, n) that depends on e and n only (scale
// invariance in m, K and δ̇⁻), e.g. 0.7885 for e = 0.8, n = 3/2. LawRestitution inverts it, so
// that a model can ask for the rebound a Newton law with e_eff would give.
namespace cosim::interface {

struct HuntCrossleyLaw {
  double stiffness = 0.0;    // K [N/m^n or N m/rad^n]
  double exponent = 1.5;     // n
  double restitution = 1.0;  // e in (0, 1]
  double speed_threshold = 1e-3;
};

// f(δ, δ̇) and its partial derivatives; zero when not in contact or when the law would pull.
struct HuntCrossleyForce {
  double f = 0.0, df_ddelta = 0.0, df_drate = 0.0;
};
HuntCrossleyForce EvaluateHuntCrossley(const HuntCrossleyLaw& law, double impact_speed, double delta, double rate);

// e_eff of the law with restitution e and exponent n (RK4 of the dimensionless contact ODE with
// 2000 steps per contact; relative accuracy ~1e-10).
double EffectiveRestitution(double e, double exponent);
// The law's e whose e_eff is `effective` (bisection on EffectiveRestitution; e_eff is
// increasing in e, EffectiveRestitution(1) = 1). `effective` in (0, 1].
double LawRestitution(double effective, double exponent);

}  // namespace cosim::interface
