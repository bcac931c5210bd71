#pragma once
// Airfoil polars over the full angle range: lift, drag and quarter-chord pitching moment
// coefficients against angle of attack α ∈ (−π, π] and Mach number, with their partial
// derivatives (for the Newton matrix of the strip loads, docs/design.md "Blade aerodynamics").
//   - C81Airfoil: the C81 table layout of rotorcraft codes (read and validated; bilinear in α
//     and Mach, constant beyond the Mach range).
//   - BuiltinNaca0012: the attached-flow fit of docs/reference/puma.md below stall, blended into a
//     flat-plate post-stall model that reaches ±180° (reverse flow).
#include <memory>
#include <string>
#include <utility>
#include <vector>

namespace cosim::smooth {

struct PolarValue {
  double cl = 0.0, cd = 0.0, cm = 0.0;
  double cl_alpha = 0.0, cd_alpha = 0.0, cm_alpha = 0.0;  // ∂/∂α [1/rad]
  double cl_mach = 0.0, cd_mach = 0.0, cm_mach = 0.0;     // ∂/∂M
};

class Airfoil {
 public:
  virtual ~Airfoil() = default;
  // α in radians, any value (wrapped into (−π, π]); M >= 0.
  virtual PolarValue Evaluate(double alpha, double mach) const = 0;
  virtual const std::string& name() const = 0;
};

// α wrapped into (−π, π].
double WrapAngle(double alpha);

// NACA 0012, built in (docs/reference/puma.md): below the stall angle α_s = 0.2269 (1 − M) rad
//   C_l = 5.7296 α / √(1 − M²),  C_d = 0.006 + 0.13131 α²,  C_m = 0;
// beyond α_s + 10° a flat plate, C_l = 1.18 sin 2α, C_d = 0.02 + 1.98 sin²α, C_m = −0.5 sin α
// (C_l ≈ ±1.18 at ±45°, C_d ≈ 2.0 at 90°, C_l = 0 and C_d = 0.02 at 180°, as the C81 tables);
// a C¹ smoothstep blend in between (the stall drop). The Prandtl–Glauert factor is held at
// M = 0.9 beyond it. Odd in α for C_l and C_m, even for C_d.
// `lift_slope` replaces 5.7296 (a deck with another attached-flow slope); stall and post-stall
// stay.
class BuiltinNaca0012 : public Airfoil {
 public:
  BuiltinNaca0012() = default;
  BuiltinNaca0012(std::string name, double lift_slope) : name_(std::move(name)), lift_slope_(lift_slope) {}
  PolarValue Evaluate(double alpha, double mach) const override;
  const std::string& name() const override { return name_; }
  double lift_slope() const { return lift_slope_; }
  static constexpr double kLiftSlope = 5.7296, kStall = 0.2269, kBlend = 10.0 * 3.14159265358979323846 / 180.0;

 private:
  std::string name_ = "naca0012";
  double lift_slope_ = kLiftSlope;
};

// One coefficient of a C81 table: values at (α_i, M_j), α in radians, increasing.
struct C81Coefficient {
  std::vector<double> mach, alpha;
  std::vector<double> value;  // value[i * mach.size() + j] at α_i, M_j
  // Value and partial derivatives at (α, M): bilinear; constant beyond the Mach range.
  void Evaluate(double alpha, double mach, double* v, double* dv_dalpha, double* dv_dmach) const;
};

// The C81 layout (fixed columns): a header line, the airfoil's name in columns 1–30 then six
// 2-column integers ML NL MD ND MM NM (Mach and α counts for lift, drag and moment); for each
// coefficient in turn, a line of Mach numbers (columns 8 on, 7 columns each, 9 per line,
// continued on further lines with 7 blank columns) and then one row per α: α [deg] in
// columns 1–7 and the coefficient at each Mach number (7 columns each, 9 per line, continued
// likewise). α must increase and cover −180° … 180°; Mach numbers must increase.
class C81Airfoil : public Airfoil {
 public:
  // Throws InputError naming `source`:line, the field and what is expected.
  static std::unique_ptr<C81Airfoil> Parse(const std::string& text, const std::string& source, std::string name);
  static std::unique_ptr<C81Airfoil> Read(const std::string& path, std::string name);
  PolarValue Evaluate(double alpha, double mach) const override;
  const std::string& name() const override { return name_; }
  const std::string& title() const { return title_; }
  const C81Coefficient& lift() const { return lift_; }

 private:
  std::string name_, title_;
  C81Coefficient lift_, drag_, moment_;
};

// Writes a table in the C81 layout from an airfoil sampled at the given α [deg] and Mach
// numbers (the same grid for the three coefficients): used to export the built-in polar and by
// the reader's tests.
std::string WriteC81(const Airfoil& airfoil, const std::string& title, const std::vector<double>& alpha_deg,
                     const std::vector<double>& mach);

}  // namespace cosim::smooth
