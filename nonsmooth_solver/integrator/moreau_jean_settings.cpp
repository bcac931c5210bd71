#include "nonsmooth_solver/integrator/moreau_jean_settings.h"

#include <string>

namespace cosim::nonsmooth {
namespace {

namespace sc = scenario;

LcpAlgorithm ToAlgorithm(const interface::Checks& checks, const std::string& path, sc::LcpSettings::Solver solver) {
  switch (solver) {
    case sc::LcpSettings::LEMKE:
      return LcpAlgorithm::kLemke;
    case sc::LcpSettings::PGS:
      return LcpAlgorithm::kPgs;
    case sc::LcpSettings::ENUMERATIVE:
      return LcpAlgorithm::kEnumerative;
    case sc::LcpSettings::NEWTON_FB:
      return LcpAlgorithm::kNewtonFischerBurmeister;
    default:
      checks.Fail(path, "expected one of LEMKE, PGS, ENUMERATIVE, NEWTON_FB" +
                            std::string(path.find("fallback") != std::string::npos ? " (or NONE alone)" : ""));
  }
}

LcpOptions ReadLcpOptions(const interface::Checks& checks, const sc::LcpSettings& lcp) {
  LcpOptions out;
  out.algorithm = ToAlgorithm(checks, "numerics.nonsmooth.lcp.solver", lcp.solver());
  out.tolerance = checks.Positive("numerics.nonsmooth.lcp.tolerance", true, lcp.tolerance(), "dimensionless");
  if (lcp.max_iterations() < 1) {
    checks.Fail("numerics.nonsmooth.lcp.max_iterations", "must be >= 1, got " + std::to_string(lcp.max_iterations()));
  }
  out.max_iterations = lcp.max_iterations();
  if (lcp.fallback_size() == 0) {
    out.fallbacks = {LcpAlgorithm::kEnumerative, LcpAlgorithm::kNewtonFischerBurmeister};
  } else if (!(lcp.fallback_size() == 1 && lcp.fallback(0) == sc::LcpSettings::NONE)) {
    for (int i = 0; i < lcp.fallback_size(); ++i) {
      out.fallbacks.push_back(
          ToAlgorithm(checks, interface::ElementPath("numerics.nonsmooth.lcp.fallback", i), lcp.fallback(i)));
    }
  }
  return out;
}

}  // namespace

MoreauJeanSettings ReadMoreauJeanSettings(const interface::Checks& checks, const sc::NonsmoothSettings& ns) {
  MoreauJeanSettings out;
  out.theta = checks.InRange("numerics.nonsmooth.theta", true, ns.theta(), 0.0, 1.0, /*lo_open=*/true);
  out.activation_gap = checks.NonNegative("numerics.nonsmooth.activation_gap", ns.activation_gap(), "m");
  out.split_independent_lcps = ns.split_independent_lcps();
  switch (ns.friction_model()) {
    case sc::NonsmoothSettings::POLYHEDRAL_LCP:
      out.friction_model = FrictionModel::kPolyhedralLcp;
      break;
    case sc::NonsmoothSettings::SICONOS_FC3D:
      out.friction_model = FrictionModel::kSiconosFc3d;
      break;
    default:
      checks.Fail("numerics.nonsmooth.friction_model", "expected POLYHEDRAL_LCP or SICONOS_FC3D");
  }
  if (ns.friction_facets() < 3 || ns.friction_facets() > 64) {
    checks.Fail(
        "numerics.nonsmooth.friction_facets",
        "must be in [3, 64] (directions of the polyhedral friction cone), got " + std::to_string(ns.friction_facets()));
  }
  out.friction_facets = ns.friction_facets();
  out.lcp = ReadLcpOptions(checks, ns.lcp());
  return out;
}

MoreauJeanSettings ReadMoreauJeanSettings(const interface::ScenarioFile& file) {
  return ReadMoreauJeanSettings(interface::Checks(file), file.proto().numerics().nonsmooth());
}

}  // namespace cosim::nonsmooth
