// Counts heap allocations inside CGα steps: after the first steps (which allocate the element
// workspaces and the integrator's start-up), a step of a model with rigid and elastic bodies
// must not allocate (assembly is allocation-free inside the step loop). malloc is
// interposed for this executable only (glibc's __libc_malloc underneath); Eigen allocates
// through malloc, operator new too. Not built under the sanitizers, which intercept malloc.
#include <gtest/gtest.h>

#include <atomic>
#include <cstdlib>
#include <string>
#include <vector>

#include "interface/scenario/scenario_file.h"
#include "smooth_solver/simulation/multibody_simulation.h"

extern "C" void* __libc_malloc(size_t);  // NOLINT
namespace {
std::atomic<long> g_allocations{0};
}
extern "C" void* malloc(size_t size) {  // NOLINT
  g_allocations.fetch_add(1, std::memory_order_relaxed);
  return __libc_malloc(size);
}

namespace cosim::smooth {
namespace {

long AllocationsInFiveSteps(const std::string& scenario, const std::vector<std::string>& settings, double h) {
  MultibodySimulation sim(interface::ScenarioFile::Load(std::string(COSIM_SOURCE_DIR) + scenario, settings));
  for (int k = 0; k < 3; ++k) sim.Step(k * h, h);  // warm-up: start-up and first-use workspaces
  const long before = g_allocations.load();
  for (int k = 3; k < 8; ++k) sim.Step(k * h, h);
  return g_allocations.load() - before;
}

TEST(Allocation, CgAlphaStepsOfRigidAndElasticBodiesDoNotAllocate) {
  // The flexible pendulum (rigid link, hinge, beam with clamps, GEMM force, structural damping)
  // and the four-bar (rigid closed loop).
  const long pendulum = AllocationsInFiveSteps("/tests/data/flexible_pendulum.pbtxt",
                                               {"model.elastic_bodies[0].retardation_time=1e-4"}, 1e-3);
  const long four_bar = AllocationsInFiveSteps("/scenarios/four_bar.pbtxt", {}, 1e-3);
  std::printf("heap allocations in five CGα steps: flexible pendulum %ld, four-bar %ld\n", pendulum, four_bar);
  EXPECT_EQ(pendulum, 0);
  EXPECT_EQ(four_bar, 0);
}

TEST(Allocation, BeamRotorStepsDoNotAllocate) {
  // The Puma rotor with beam blades (the speed benchmark's scene): element kernels on bounded local
  // Eigen types, section stiffness and reference strains stored per Gauss point.
  const long rotor = AllocationsInFiveSteps("/scenarios/puma/rotor_no_air.pbtxt", {}, 1e-4);
  std::printf("heap allocations in five CGα steps of the Puma beam rotor: %ld\n", rotor);
  EXPECT_EQ(rotor, 0);
  // With air: strip loads on bounded local matrices, the rotor's inflow solved at each accepted
  // step without containers, the probes' sections built on the stack.
  const long air = AllocationsInFiveSteps("/scenarios/puma/rotor_air.pbtxt", {}, 1e-4);
  std::printf("heap allocations in five CGα steps of the Puma beam rotor in air: %ld\n", air);
  EXPECT_EQ(air, 0);
}

TEST(Allocation, RotorStopForceElementsDoNotAllocate) {
  // Joint springs, joint stops and continuous contacts (the rotor stops' force elements)
  // evaluated their measure with dynamic Eigen objects: 45 allocations in five steps of
  // pendulum_stop_continuous. Each is here in contact (its force and tangent evaluated) in the
  // measured steps.
  const long joint = AllocationsInFiveSteps(
      "/tests/data/rigid_pendulum.pbtxt",
      {"model.forces=[{ name: \"stop\" joint_stop { joint: \"hinge\" lower: 0.05 upper: 1 "
       "law { stiffness: 1e4 restitution: 0.8 } } }, { name: \"spring\" joint_spring { joint: \"hinge\" "
       "stiffness: 10 damping: 0.1 } }]"},
      1e-3);
  const long contact = AllocationsInFiveSteps("/tests/data/tied_drop_continuous.pbtxt",
                                              {"model.bodies[0].position=[0, 0, -0.001]"}, 1e-3);
  const long pendulum_stop = AllocationsInFiveSteps("/scenarios/pendulum_stop_continuous.pbtxt", {}, 1e-3);
  std::printf(
      "heap allocations in five CGα steps: joint stop + spring %ld, continuous contact %ld, "
      "pendulum_stop_continuous %ld\n",
      joint, contact, pendulum_stop);
  EXPECT_EQ(joint, 0);
  EXPECT_EQ(contact, 0);
  EXPECT_EQ(pendulum_stop, 0);
}

}  // namespace
}  // namespace cosim::smooth
