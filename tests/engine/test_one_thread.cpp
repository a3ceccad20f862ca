// One thread at a time on a world (decision 0100): a second thread's step or change while a step
// runs is refused with Error{busy} and changes nothing, and so is a call from inside the step.
// The threads run in lockstep through a host job system that blocks inside the step: no timing.
#include <doctest/doctest.h>

#include <functional>
#include <thread>
#include <vector>

#include "haustra/error.hpp"
#include "lockstep_jobs.hpp"
#include "scene_fixtures.hpp"

namespace haustra {
namespace {

std::unique_ptr<World> world_on(LockstepJobs& jobs) {
  SceneDesc scene = test::scene_desc("two-segments");  // two rods: per-segment stages go to the jobs
  scene.world.jobs = {&LockstepJobs::enqueue, &LockstepJobs::wait, &jobs, 2};
  return create_world(scene);
}

// The message of the busy error `call` throws (fails the test if it throws none or another).
std::string busy_message(const std::function<void()>& call) {
  try {
    call();
  } catch (const Error& e) {
    CHECK(e.code() == ErrorCode::busy);
    return e.what();
  }
  FAIL_CHECK("not refused");
  return {};
}

TEST_CASE("one thread at a time: a second thread's step, change or mesh read during a step is refused as busy") {
  LockstepJobs jobs;
  auto w = world_on(jobs);
  auto reference = test::scene_world("two-segments");
  test::step_both(*w, *reference, 5);
  std::vector<std::string> messages;
  jobs.arm();
  std::thread other([&] {
    jobs.while_stepping([&] {
      messages.push_back(busy_message([&] { w->step(); }));
      messages.push_back(busy_message([&] { w->set_gravity({0.0, 0.0, -1.0}); }));
      messages.push_back(busy_message([&] { w->set_external_load(3, {1.0, 0.0, 0.0}, Eigen::Vector3d::Zero()); }));
      messages.push_back(busy_message([&] { (void)w->mesh_positions(); }));
      messages.push_back(busy_message([&] { (void)w->save_checkpoint(); }));
      messages.push_back(busy_message([&] { w->restore_checkpoint(std::vector<std::byte>{}); }));
    });
  });
  w->step();  // the step the other thread ran into
  jobs.stepped();
  other.join();
  REQUIRE(messages.size() == 6);
  CHECK(messages[0] ==
        "World::step: the world is in use by another thread: one thread at a time steps, changes or "
        "reads a world's meshes (decision 0100); call again once its call returns");
  CHECK(messages[1].find("World::set_gravity: the world is in use by another thread") == 0);
  CHECK(messages[3].find("World::mesh_positions: the world is in use") == 0);
  // Nothing the refused calls would have done was done: the world steps on as one never disturbed.
  reference->step();
  test::step_both(*w, *reference, 10);
  CHECK(test::positions(*w) == test::positions(*reference));
  CHECK(w->gravity() == reference->gravity());
}

TEST_CASE("one thread at a time: a call from inside the world's own step, on the stepping thread, is refused") {
  LockstepJobs jobs;
  auto w = world_on(jobs);
  std::string message;
  jobs.arm([&] { message = busy_message([&] { w->set_dt(0.01); }); });
  std::thread other([&] { jobs.while_stepping([] {}); });
  w->step();
  jobs.stepped();
  other.join();
  CHECK(message ==
        "World::set_dt: called from inside a step of this world (a job system's callback?): the world "
        "takes calls again once its step returns");
  CHECK(w->dt() == doctest::Approx(1.0 / 60.0));
  w->set_dt(0.01);  // after the step, the same thread may
  CHECK(w->dt() == 0.01);
}

}  // namespace
}  // namespace haustra
