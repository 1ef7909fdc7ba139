// Microbenchmarks of the Lie-group and quaternion operations used in every tracker and filter
// step: SE3/SO3 exp and log, composition, the left Jacobian, and the thesis' quaternion product.
#include <benchmark/benchmark.h>

#include "kestrel/geometry/quaternion.hpp"
#include "kestrel/geometry/se3.hpp"
#include "kestrel/geometry/so3.hpp"

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

void BM_Se3LeftJacobian(benchmark::State& state) {
  kestrel::Vector6d xi = twist();
  for (auto _ : state) {
    benchmark::DoNotOptimize(kestrel::SE3::left_jacobian(xi));
    xi[3] += 1e-9;
  }
}
BENCHMARK(BM_Se3LeftJacobian);

// Rotation vectors of a typical inter-frame angle (0.87 rad) and of one below the series
// switch (1e-5 rad), which takes the Taylor branch.
const Eigen::Vector3d kOmega(0.4, -0.5, 0.6);
const Eigen::Vector3d kTinyOmega(4e-6, -5e-6, 6e-6);

void BM_So3Exp(benchmark::State& state, const Eigen::Vector3d& omega) {
  Eigen::Vector3d w = omega;
  for (auto _ : state) {
    benchmark::DoNotOptimize(kestrel::SO3::exp(w));
    w.x() += 1e-12;
  }
}
BENCHMARK_CAPTURE(BM_So3Exp, typical, kOmega);
BENCHMARK_CAPTURE(BM_So3Exp, tiny, kTinyOmega);

void BM_So3Log(benchmark::State& state, const Eigen::Vector3d& omega) {
  const kestrel::SO3 R = kestrel::SO3::exp(omega);
  for (auto _ : state) benchmark::DoNotOptimize(R.log());
}
BENCHMARK_CAPTURE(BM_So3Log, typical, kOmega);
BENCHMARK_CAPTURE(BM_So3Log, tiny, kTinyOmega);

void BM_So3LeftJacobian(benchmark::State& state, const Eigen::Vector3d& omega) {
  Eigen::Vector3d w = omega;
  for (auto _ : state) {
    benchmark::DoNotOptimize(kestrel::SO3::left_jacobian(w));
    w.x() += 1e-12;
  }
}
BENCHMARK_CAPTURE(BM_So3LeftJacobian, typical, kOmega);
BENCHMARK_CAPTURE(BM_So3LeftJacobian, tiny, kTinyOmega);

void BM_So3LeftJacobianInverse(benchmark::State& state) {
  Eigen::Vector3d w = kOmega;
  for (auto _ : state) {
    benchmark::DoNotOptimize(kestrel::SO3::left_jacobian_inverse(w));
    w.x() += 1e-12;
  }
}
BENCHMARK(BM_So3LeftJacobianInverse);

void BM_QuaternionMultiply(benchmark::State& state) {
  const kestrel::quat::Quat q1(0.5, 0.1, -0.7, 0.5);
  kestrel::quat::Quat q2(0.9, -0.3, 0.2, 0.2);
  for (auto _ : state) {
    q2 = kestrel::quat::multiply(q1, q2).normalized();
    benchmark::DoNotOptimize(q2);
  }
}
BENCHMARK(BM_QuaternionMultiply);

// Eigen's Hamilton product, the baseline for the thesis' written-out formula above.
void BM_EigenQuaternionMultiply(benchmark::State& state) {
  const Eigen::Quaterniond q1 = Eigen::Quaterniond(0.5, 0.1, -0.7, 0.5).normalized();
  Eigen::Quaterniond q2 = Eigen::Quaterniond(0.9, -0.3, 0.2, 0.2).normalized();
  for (auto _ : state) {
    q2 = (q1 * q2).normalized();
    benchmark::DoNotOptimize(q2);
  }
}
BENCHMARK(BM_EigenQuaternionMultiply);

}  // namespace
