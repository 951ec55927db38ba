// ricci tool — known-answer convergence of the conformal signature under refinement, as Markdown
// tables (tools/SIGNATURE-convergence.md): tori of revolution (τ = i·√((R/r)² − 1), reduced) and
// conformally mapped annuli (modulus log(r2/r1)/2π), each at three resolutions, with the error and
// the ratio of successive errors (4 for second order). A benchmark, not a test: it prints.
#include <chrono>
#include <cmath>
#include <complex>
#include <cstdio>
#include <numbers>

#include "ricci/signature.h"
#include "ricci/uniformize.h"
#include "ricci/validate.h"
#include "shapes.h"

namespace {

ricci::ConformalSignature signature_of(const ricci::Mesh& mesh, double& seconds) {
  const auto t0 = std::chrono::steady_clock::now();
  ricci::ConformalSignature s;
  const ricci::ValidateResult v = ricci::validate_mesh(mesh);
  if (v.status != ricci::Status::Ok) {
    s.message = v.message;
    return s;
  }
  ricci::UniformizeOptions o;
  o.seed_checks = 0;
  s = ricci::conformal_signature(ricci::uniformize(v.mesh, v.topology, o));
  seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return s;
}

}  // namespace

int main() {
  std::printf("## Tori of revolution: tau = i sqrt((R/r)^2 - 1), reduced\n\n");
  std::printf("| R/r | grid | faces | tau computed | exact | error | error ratio | stated uncertainty | seconds |\n");
  std::printf("|---|---|---|---|---|---|---|---|---|\n");
  for (const double ratio : {1.5, 2.0, 3.0}) {
    const double s = std::sqrt(ratio * ratio - 1), exact = std::max(s, 1 / s);
    double previous = NAN;
    for (const int nv : {12, 24, 48}) {
      const int nu = static_cast<int>(std::lround(nv * ratio));
      double seconds = 0;
      const ricci::ConformalSignature sig = signature_of(ricci_shapes::torus(nu, nv, ratio, 1.0), seconds);
      if (sig.status != ricci::Status::Ok) {
        std::printf("| %g | %dx%d | | failed: %s | | | | | |\n", ratio, nu, nv, sig.message.c_str());
        continue;
      }
      const double err = std::abs(sig.torus.tau - std::complex<double>(0, exact));
      std::printf("| %g | %dx%d | %d | %.10f%+.10fi | %.10fi | %.3e | %s | %.1e | %.2f |\n", ratio, nu, nv, 2 * nu * nv,
                  sig.torus.tau.real(), sig.torus.tau.imag(), exact, err,
                  std::isnan(previous) ? "" : std::to_string(previous / err).substr(0, 5).c_str(), sig.torus.uncertainty,
                  seconds);
      previous = err;
    }
  }
  std::printf("\n## Conformally mapped annuli: modulus log(r2/r1)/2pi\n\n");
  std::printf("| r1/r2 | rings x segments | faces | modulus computed | exact | error | error ratio | stated uncertainty | seconds |\n");
  std::printf("|---|---|---|---|---|---|---|---|---|\n");
  for (const double r1 : {0.2, 0.4, 0.7}) {
    const double exact = std::log(1 / r1) / (2 * std::numbers::pi);
    double previous = NAN;
    for (const int segments : {24, 48, 96}) {
      const int rings = std::max(1, static_cast<int>(std::lround(segments * std::log(1 / r1) / (std::numbers::pi * std::sqrt(3.0)))));
      double seconds = 0;
      const ricci::ConformalSignature sig = signature_of(ricci_shapes::conformal_annulus(r1, 1.0, rings, segments), seconds);
      if (sig.status != ricci::Status::Ok || !sig.has_circle_domain) {
        std::printf("| %g | %dx%d | | failed: %s | | | | | |\n", r1, rings, segments, sig.message.c_str());
        continue;
      }
      const double m = sig.circle_domain.annulus_modulus, err = std::abs(m - exact);
      std::printf("| %g | %dx%d | %d | %.10f | %.10f | %.3e | %s | %.1e | %.2f |\n", r1, rings, segments,
                  2 * rings * segments, m, exact, err,
                  std::isnan(previous) ? "" : std::to_string(previous / err).substr(0, 5).c_str(),
                  sig.circle_domain.annulus_modulus_uncertainty, seconds);
      previous = err;
    }
  }
  return 0;
}
