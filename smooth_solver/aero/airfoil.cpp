#include "smooth_solver/aero/airfoil.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <sstream>

#include "interface/base/errors.h"
#include "interface/base/input_file.h"
#include "interface/scenario/checks.h"

namespace cosim::smooth {

namespace {
constexpr double kPi = 3.14159265358979323846;
}  // namespace

double WrapAngle(double alpha) {
  if (alpha > -kPi && alpha <= kPi) return alpha;
  double a = std::fmod(alpha + kPi, 2.0 * kPi);
  if (a <= 0.0) a += 2.0 * kPi;
  return a - kPi;
}

PolarValue BuiltinNaca0012::Evaluate(double alpha, double mach) const {
  alpha = WrapAngle(alpha);
  const double s = alpha >= 0.0 ? 1.0 : -1.0, a = std::abs(alpha);
  // Prandtl–Glauert factor β and the stall angle α_s, held beyond M = 0.9.
  const bool compressible = mach < 0.9;
  const double mc = std::min(std::max(mach, 0.0), 0.9);
  const double beta = std::sqrt(1.0 - mc * mc), dbeta_dm = compressible ? -mc / beta : 0.0;
  const double alpha_s = kStall * (1.0 - mc), dalpha_s_dm = compressible ? -kStall : 0.0;
  // Attached flow (puma.md fit) and flat plate: value, ∂/∂a, ∂/∂M for (cl, cd, cm).
  const double att[3] = {lift_slope_ * a / beta, 0.006 + 0.13131 * a * a, 0.0};
  const double att_a[3] = {lift_slope_ / beta, 2.0 * 0.13131 * a, 0.0};
  const double att_m[3] = {-lift_slope_ * a / (beta * beta) * dbeta_dm, 0.0, 0.0};
  const double sa = std::sin(a), ca = std::cos(a);
  const double fp[3] = {1.18 * 2.0 * sa * ca, 0.02 + 1.98 * sa * sa, -0.5 * sa};
  const double fp_a[3] = {2.36 * (ca * ca - sa * sa), 1.98 * 2.0 * sa * ca, -0.5 * ca};
  // Smoothstep weight of the flat plate over [α_s, α_s + Δ].
  const double x = (a - alpha_s) / kBlend;
  double w = 1.0, dw_dx = 0.0;
  if (x <= 0.0) {
    w = 0.0;
  } else if (x < 1.0) {
    w = x * x * (3.0 - 2.0 * x);
    dw_dx = 6.0 * x * (1.0 - x);
  }
  const double w_a = dw_dx / kBlend, w_m = -dw_dx / kBlend * dalpha_s_dm;
  double v[3], v_a[3], v_m[3];
  for (int k = 0; k < 3; ++k) {
    v[k] = (1.0 - w) * att[k] + w * fp[k];
    v_a[k] = (1.0 - w) * att_a[k] + w * fp_a[k] + w_a * (fp[k] - att[k]);
    v_m[k] = (1.0 - w) * att_m[k] + w_m * (fp[k] - att[k]);
  }
  // C_l and C_m odd in α, C_d even: d(s f(|α|))/dα = f′(|α|), d f(|α|)/dα = s f′(|α|).
  PolarValue p;
  p.cl = s * v[0];
  p.cl_alpha = v_a[0];
  p.cl_mach = s * v_m[0];
  p.cd = v[1];
  p.cd_alpha = s * v_a[1];
  p.cd_mach = v_m[1];
  p.cm = s * v[2];
  p.cm_alpha = v_a[2];
  p.cm_mach = s * v_m[2];
  return p;
}

void C81Coefficient::Evaluate(double a, double m, double* v, double* dv_da, double* dv_dm) const {
  a = WrapAngle(a);
  const size_t na = alpha.size(), nm = mach.size();
  // α interval (the table covers ±π; clamp for round-off at the ends).
  size_t i = static_cast<size_t>(std::upper_bound(alpha.begin(), alpha.end(), a) - alpha.begin());
  i = std::min(std::max<size_t>(i, 1), na - 1) - 1;
  const double da = alpha[i + 1] - alpha[i];
  const double ta = std::min(std::max((a - alpha[i]) / da, 0.0), 1.0);
  // Mach interval; constant beyond the table.
  size_t j = 0;
  double tm = 0.0, dm = 1.0;
  bool inside = false;
  if (nm > 1) {
    if (m <= mach.front()) {
      j = 0;
    } else if (m >= mach.back()) {
      j = nm - 2;
      tm = 1.0;
    } else {
      j = static_cast<size_t>(std::upper_bound(mach.begin(), mach.end(), m) - mach.begin()) - 1;
      dm = mach[j + 1] - mach[j];
      tm = (m - mach[j]) / dm;
      inside = true;
    }
  }
  auto at = [&](size_t ii, size_t jj) { return value[ii * nm + std::min(jj, nm - 1)]; };
  const double v00 = at(i, j), v10 = at(i + 1, j), v01 = at(i, j + 1), v11 = at(i + 1, j + 1);
  const double low = v00 + ta * (v10 - v00), high = v01 + ta * (v11 - v01);
  *v = nm > 1 ? low + tm * (high - low) : low;
  const double slope_low = (v10 - v00) / da, slope_high = (v11 - v01) / da;
  *dv_da = nm > 1 ? slope_low + tm * (slope_high - slope_low) : slope_low;
  *dv_dm = inside ? (high - low) / dm : 0.0;
}

PolarValue C81Airfoil::Evaluate(double alpha, double mach) const {
  PolarValue p;
  lift_.Evaluate(alpha, mach, &p.cl, &p.cl_alpha, &p.cl_mach);
  drag_.Evaluate(alpha, mach, &p.cd, &p.cd_alpha, &p.cd_mach);
  moment_.Evaluate(alpha, mach, &p.cm, &p.cm_alpha, &p.cm_mach);
  return p;
}

namespace {

// Reads the fixed-column C81 layout line by line.
class C81Reader {
 public:
  C81Reader(const std::string& text, std::string source) : source_(std::move(source)) {
    std::istringstream in(text);
    std::string line;
    while (std::getline(in, line)) {
      if (!line.empty() && line.back() == '\r') line.pop_back();
      lines_.push_back(line);
    }
  }
  [[noreturn]] void Fail(size_t line, const std::string& message) const {
    throw InputError(source_ + ":" + std::to_string(line + 1) + ": " + message);
  }
  const std::string& Line(size_t k, const std::string& what) const {
    if (k >= lines_.size()) Fail(lines_.size() > 0 ? lines_.size() - 1 : 0, "the table ends before " + what);
    return lines_[k];
  }
  // The number in columns [first, first + width) of line k (1-based columns in messages).
  double Number(size_t k, size_t first, size_t width, const std::string& what) const {
    const std::string& l = Line(k, what);
    std::string field = first < l.size() ? l.substr(first, width) : "";
    const auto b = field.find_first_not_of(" \t"), e = field.find_last_not_of(" \t");
    const std::string where =
        "columns " + std::to_string(first + 1) + "-" + std::to_string(first + width) + " (" + what + ")";
    if (b == std::string::npos) Fail(k, where + " are empty; expected a number");
    field = field.substr(b, e - b + 1);
    char* end = nullptr;
    const double v = std::strtod(field.c_str(), &end);
    if (end != field.c_str() + field.size() || !std::isfinite(v)) {
      Fail(k, where + " hold '" + field + "'; expected a number");
    }
    return v;
  }
  // `count` numbers of 7 columns from column 8 on, 9 per line, starting at line *k.
  std::vector<double> Row(size_t* k, size_t count, const std::string& what) const {
    std::vector<double> v;
    for (size_t n = 0; n < count; ++n) {
      if (n > 0 && n % 9 == 0) {
        ++*k;
        const std::string& l = Line(*k, what + " (continuation line)");
        if (l.substr(0, std::min<size_t>(7, l.size())).find_first_not_of(' ') != std::string::npos) {
          Fail(*k, "a continuation line of " + what + " must start with 7 blank columns");
        }
      }
      v.push_back(Number(*k, 7 + 7 * (n % 9), 7, what + " " + std::to_string(n + 1)));
    }
    ++*k;
    return v;
  }
  size_t size() const { return lines_.size(); }
  const std::string& source() const { return source_; }

 private:
  std::string source_;
  std::vector<std::string> lines_;
};

C81Coefficient ReadCoefficient(const C81Reader& r, size_t* k, int n_mach, int n_alpha, const std::string& what) {
  C81Coefficient c;
  const size_t mach_line = *k;
  c.mach = r.Row(k, static_cast<size_t>(n_mach), what + " Mach number");
  for (size_t j = 1; j < c.mach.size(); ++j) {
    if (!(c.mach[j] > c.mach[j - 1])) r.Fail(mach_line, what + " Mach numbers must increase");
  }
  for (double m : c.mach) {
    if (m < 0.0) r.Fail(mach_line, what + " Mach number " + interface::FormatNumber(m) + " is negative");
  }
  c.value.reserve(static_cast<size_t>(n_mach * n_alpha));
  for (int i = 0; i < n_alpha; ++i) {
    const size_t line = *k;
    const double a_deg = r.Number(line, 0, 7, what + " angle of attack [deg]");
    if (!c.alpha.empty() && !(a_deg * kPi / 180.0 > c.alpha.back())) {
      r.Fail(line, what + " angle of attack " + interface::FormatNumber(a_deg) + " deg does not increase");
    }
    c.alpha.push_back(a_deg * kPi / 180.0);
    const std::vector<double> row = r.Row(k, static_cast<size_t>(n_mach), what + " coefficient");
    c.value.insert(c.value.end(), row.begin(), row.end());
  }
  const double lo = c.alpha.front() * 180.0 / kPi, hi = c.alpha.back() * 180.0 / kPi;
  if (lo > -180.0 + 1e-9 || hi < 180.0 - 1e-9) {
    r.Fail(mach_line, what + " angles of attack span " + interface::FormatNumber(lo) + " … " +
                          interface::FormatNumber(hi) +
                          " deg; the table must cover -180 … 180 deg (a still or slow rotor sees reverse flow)");
  }
  return c;
}

}  // namespace

std::unique_ptr<C81Airfoil> C81Airfoil::Parse(const std::string& text, const std::string& source, std::string name) {
  const C81Reader r(text, source);
  auto airfoil = std::unique_ptr<C81Airfoil>(new C81Airfoil());
  airfoil->name_ = std::move(name);
  const std::string& header = r.Line(0, "the header line");
  airfoil->title_ = header.substr(0, std::min<size_t>(30, header.size()));
  int counts[6];
  const char* labels[6] = {"ML (lift Mach count)",  "NL (lift alpha count)",  "MD (drag Mach count)",
                           "ND (drag alpha count)", "MM (moment Mach count)", "NM (moment alpha count)"};
  for (int c = 0; c < 6; ++c) {
    const double v = r.Number(0, 30 + 2 * static_cast<size_t>(c), 2, labels[c]);
    if (v != std::floor(v) || v < 1.0) {
      r.Fail(0, std::string(labels[c]) + " is " + interface::FormatNumber(v) + "; expected a positive integer");
    }
    counts[c] = static_cast<int>(v);
  }
  for (int c = 1; c < 6; c += 2) {
    if (counts[c] < 2) r.Fail(0, std::string(labels[c]) + " must be at least 2");
  }
  size_t k = 1;
  airfoil->lift_ = ReadCoefficient(r, &k, counts[0], counts[1], "lift");
  airfoil->drag_ = ReadCoefficient(r, &k, counts[2], counts[3], "drag");
  airfoil->moment_ = ReadCoefficient(r, &k, counts[4], counts[5], "moment");
  for (; k < r.size(); ++k) {
    if (r.Line(k, "").find_first_not_of(" \t") != std::string::npos) {
      r.Fail(k, "text after the moment table; the header's counts may be wrong");
    }
  }
  return airfoil;
}

std::unique_ptr<C81Airfoil> C81Airfoil::Read(const std::string& path, std::string name) {
  // (Measured before it is read: a 6 GiB file used to be read whole, then refused.)
  const interface::InputFile f = interface::ReadInputFile(path, interface::kMaxAirfoilBytes);
  if (!f.ok()) throw InputError(f.why + "; expected a C81 airfoil table");
  return Parse(f.text, path, std::move(name));
}

std::string WriteC81(const Airfoil& airfoil, const std::string& title, const std::vector<double>& alpha_deg,
                     const std::vector<double>& mach) {
  std::string out;
  char buf[64];
  std::string t = title.substr(0, 30);
  t.resize(30, ' ');
  out += t;
  const int nm = static_cast<int>(mach.size()), na = static_cast<int>(alpha_deg.size());
  if (nm < 1 || nm > 99 || na < 2 || na > 99) {
    throw InputError("WriteC81: " + std::to_string(na) + " angles and " + std::to_string(nm) +
                     " Mach numbers; the C81 header's 2-column counts allow 2..99 and 1..99");
  }
  for (int c = 0; c < 3; ++c) {
    std::snprintf(buf, sizeof buf, "%2d%2d", nm, na);
    out += buf;
  }
  out += "\n";
  // Values 7 columns wide, 9 per line (Mach numbers with 3 decimals, coefficients with 4).
  auto row = [&](const std::string& first, const std::vector<double>& values, bool mach_line) {
    out += first;
    for (size_t n = 0; n < values.size(); ++n) {
      if (n > 0 && n % 9 == 0) out += "\n       ";
      if (mach_line) {
        std::snprintf(buf, sizeof buf, "%7.3f", values[n]);
      } else {
        std::snprintf(buf, sizeof buf, "%7.4f", values[n]);
      }
      out += buf;
    }
    out += "\n";
  };
  for (int c = 0; c < 3; ++c) {
    row("       ", mach, true);
    for (double a : alpha_deg) {
      std::vector<double> values;
      for (double m : mach) {
        const PolarValue p = airfoil.Evaluate(a * kPi / 180.0, m);
        values.push_back(c == 0 ? p.cl : c == 1 ? p.cd : p.cm);
      }
      std::snprintf(buf, sizeof buf, "%7.2f", a);
      row(std::string(buf), values, false);
    }
  }
  return out;
}

}  // namespace cosim::smooth
