// The int8 network runs without touching the heap once its executor exists.
#include <gtest/gtest.h>

#include <vector>

#include "support/alloc_counter.h"
#include "nn/executor.h"
#include "nn/nn_test_util.h"

namespace ef {
namespace {

TEST(NnZeroAlloc, InferenceAllocatesNothing) {
  ASSERT_TRUE(test::allocation_counting_enabled());
  auto bytes = nn::serialize_model(test::tiny_net());
  ASSERT_TRUE(bytes.ok());
  auto model = nn::load_model_memory(bytes->data(), bytes->size(), "tiny.efm");
  ASSERT_TRUE(model.ok());
  auto ex = nn::Executor::create(*model);
  ASSERT_TRUE(ex.ok());
  std::vector<float> in((*ex)->input_floats(), 100.0f), out((*ex)->output_floats());
  std::vector<int8_t> q((*ex)->input_floats(), 3);
  ASSERT_TRUE((*ex)->run(in.data(), in.size(), out.data(), out.size()).ok());  // warm-up
  test::AllocationCounter count;
  for (int i = 0; i < 5; ++i) {
    in[i] = float(i);
    const Status s = (*ex)->run(in.data(), in.size(), out.data(), out.size());
    EXPECT_TRUE(s.ok());
    const Status s2 = (*ex)->run_quantized(q.data(), q.size(), out.data(), out.size());
    EXPECT_TRUE(s2.ok());
  }
  EXPECT_EQ(count.thread_allocations(), 0u);
}

// With a two-thread pool splitting the convolutions: no allocation on any thread.
TEST(NnZeroAlloc, PooledInferenceAllocatesNothing) {
  auto bytes = nn::serialize_model(test::tiny_net());
  ASSERT_TRUE(bytes.ok());
  auto model = nn::load_model_memory(bytes->data(), bytes->size(), "tiny.efm");
  ASSERT_TRUE(model.ok());
  ThreadPoolOptions po;
  po.threads = 2;
  auto pool = ThreadPool::create(po);
  ASSERT_TRUE(pool.ok());
  nn::ExecutorOptions eo;
  eo.pool = pool->get();
  auto ex = nn::Executor::create(*model, eo);
  ASSERT_TRUE(ex.ok());
  std::vector<float> in((*ex)->input_floats(), 50.0f), out((*ex)->output_floats());
  ASSERT_TRUE((*ex)->run(in.data(), in.size(), out.data(), out.size()).ok());  // warm-up
  test::AllocationCounter count;
  for (int i = 0; i < 5; ++i) {
    in[i] = float(i);
    EXPECT_TRUE((*ex)->run(in.data(), in.size(), out.data(), out.size()).ok());
  }
  EXPECT_EQ(count.global_allocations(), 0u);
}

}  // namespace
}  // namespace ef
