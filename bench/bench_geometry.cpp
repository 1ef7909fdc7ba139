// Microbenchmarks of the Lie-group operations used in every tracker and filter step.
#include <benchmark/benchmark.h>

#include "kestrel/geometry/se3.hpp"

namespace {

kestrel::Vector6d twist() {
  kestrel::Vector6d xi;
  xi << 0.1, -0.2, 0.3, 0.4, -0.5, 0.6;
  return xi;
}

void BM_Se3Exp(benchmark::State& state) {
  kestrel::Vector6d xi = twist();
  for (auto _ : state) {
    benchmark::DoNotOptimize(kestrel::SE3::exp(xi));
    xi[0] += 1e-9;
  }
}
BENCHMARK(BM_Se3Exp);

void BM_Se3Log(benchmark::State& state) {
  const kestrel::SE3 T = kestrel::SE3::exp(twist());
  for (auto _ : state) benchmark::DoNotOptimize(T.log());
}
BENCHMARK(BM_Se3Log);

void BM_Se3Compose(benchmark::State& state) {
  const kestrel::SE3 A = kestrel::SE3::exp(twist());
  kestrel::SE3 B = A;
  for (auto _ : state) {
    B = A * B;
    benchmark::DoNotOptimize(B);
  }
}
BENCHMARK(BM_Se3Compose);

}  // namespace
