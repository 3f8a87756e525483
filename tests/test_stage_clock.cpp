// StageClock's wall time and its "other" stage (the gaps between stages), and the trace recorder
// (core/base/trace.h) that the clock's stages and the backends write to. The reference is the
// steady clock read here, around the clock under test.
#include <chrono>
#include <thread>

#include <gtest/gtest.h>

#include "core/base/stage_clock.h"
#include "core/base/trace.h"

namespace mchex {
namespace {

using namespace std::chrono_literals;

double since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

TEST(StageClock, StagesAndTheGapsBetweenThemSumToTheWallTime) {
  const auto t0 = std::chrono::steady_clock::now();
  StageClock clock(true);
  clock.run("a", [] { std::this_thread::sleep_for(10ms); });
  std::this_thread::sleep_for(30ms);  // e.g. opening a backend: in no stage
  clock.run("b", [] { std::this_thread::sleep_for(10ms); });
  clock.run("a", [] { std::this_thread::sleep_for(5ms); });
  const double outside = since(t0);
  const nlohmann::json j = clock.to_json();
  EXPECT_DOUBLE_EQ(j["a"].get<double>(), clock.seconds("a"));  // both runs of a, not the last
  EXPECT_GE(j["a"].get<double>(), 0.015);
  EXPECT_GE(j["other"].get<double>(), 0.030);
  EXPECT_NEAR(j["a"].get<double>() + j["b"].get<double>() + j["other"].get<double>(), j["total"].get<double>(), 1e-12);
  EXPECT_EQ(j["total"].get<double>(), clock.total());
  EXPECT_GE(clock.total(), 0.055);
  EXPECT_LE(clock.total(), outside);
}

TEST(Trace, RecordsStagesGapsAndSpansOnlyWhileStarted) {
  trace::start();
  StageClock clock(true);
  std::this_thread::sleep_for(5ms);
  clock.run("a", [] {
    trace::Span span("kernel", trace::kDispatch);
    span.arg("work_items", 64);
    std::this_thread::sleep_for(2ms);
  });
  std::thread([] { trace::Span span("copy", trace::kUpload); }).join();
  trace::stop();
  { trace::Span ignored("late", trace::kDownload); }
  clock.run("b", [] {});
  const std::vector<trace::Event> events = trace::events();
  ASSERT_EQ(events.size(), 4u);  // kernel, other, a, copy: nothing after stop()
  EXPECT_EQ(events[0].name, "kernel");
  EXPECT_EQ(events[0].args["work_items"], 64);
  EXPECT_EQ(events[1].name, "other");
  EXPECT_EQ(events[1].category, trace::kStage);
  EXPECT_GE(events[1].duration, 5ms);
  EXPECT_EQ(events[2].name, "a");
  EXPECT_EQ(events[1].start + events[1].duration, events[2].start);  // contiguous
  EXPECT_LE(events[2].start, events[0].start);                       // the kernel inside its stage
  EXPECT_GE(events[2].start + events[2].duration, events[0].start + events[0].duration);
  EXPECT_NE(events[3].thread, events[0].thread);
  const nlohmann::json j = trace::to_json({{"k", 1}});
  ASSERT_EQ(j["traceEvents"].size(), 5u);  // and the process name
  for (const auto& e : j["traceEvents"]) {
    if (e["ph"] == "M") continue;
    EXPECT_EQ(e["ph"], "X");
    EXPECT_GE(e["ts"].get<double>(), 0);
    EXPECT_GE(e["dur"].get<double>(), 0);
  }
  EXPECT_EQ(j["otherData"]["k"], 1);
}

}  // namespace
}  // namespace mchex
