// One model queried from many threads at once (built and run by dynaslice-ffi/tests/hosts.rs).
//
// Usage: threads_test MODEL.dsm THREADS
//
// Every thread runs the same queries as a single-threaded reference run (single points, their
// gradients and labels, and batches) on the one shared, const DsModel, all starting together;
// every answer must be bit-identical to the reference. Each thread also provokes its own error
// and checks that ds_last_error_message is thread-local.
#include "dynaslice.h"

#include <atomic>
#include <cstdio>
#include <cstring>
#include <string>
#include <thread>
#include <vector>

namespace {

struct Answers {
    std::vector<float> f, grad, batch_f, batch_grad;
    std::vector<uint32_t> labels, batch_labels;
    bool ok = true;
    std::string failure;
};

constexpr size_t kPoints = 1500;
constexpr int kRounds = 3;

void fail(Answers &a, const std::string &what) {
    if (a.ok) a.failure = what;
    a.ok = false;
}

// All the queries, in a fixed order; `thread` only selects which error to provoke.
Answers query(const DsModel *m, const std::vector<float> &xyz, const std::vector<float> &t,
              int thread) {
    const size_t k = ds_num_classes(m);
    Answers a;
    a.f.resize(kPoints * k);
    a.grad.resize(kPoints * k * 3);
    a.labels.resize(kPoints);
    a.batch_f.resize(kPoints * k);
    a.batch_grad.resize(kPoints * k * 3);
    a.batch_labels.resize(kPoints);
    for (int round = 0; round < kRounds; round++) {
        for (size_t i = 0; i < kPoints; i++) {
            if (ds_eval_grad(m, &xyz[3 * i], t[i], &a.f[i * k], &a.grad[3 * i * k], k) != DS_OK ||
                ds_label(m, &xyz[3 * i], t[i], &a.labels[i]) != DS_OK)
                fail(a, "single-point query failed");
        }
        if (ds_eval_batch(m, kPoints, xyz.data(), t.data(), a.batch_f.data()) != DS_OK ||
            ds_eval_grad_batch(m, kPoints, xyz.data(), t.data(), a.batch_f.data(),
                               a.batch_grad.data()) != DS_OK ||
            ds_label_batch(m, kPoints, xyz.data(), t.data(), a.batch_labels.data()) != DS_OK)
            fail(a, "batch query failed");
        // A per-thread failure whose message names this thread's class number.
        char name[8];
        const uint32_t bad_class = 1000 + static_cast<uint32_t>(thread);
        if (ds_class_name(m, bad_class, name, sizeof name) != DS_E_NO_SUCH_CLASS)
            fail(a, "bad class accepted");
        const std::string want = "no class " + std::to_string(bad_class);
        std::this_thread::yield();  // let other threads record their own errors meanwhile
        if (std::strstr(ds_last_error_message(), want.c_str()) == nullptr)
            fail(a, std::string("last error is not thread-local: ") + ds_last_error_message());
    }
    return a;
}

bool same_bits(const std::vector<float> &a, const std::vector<float> &b) {
    return a.size() == b.size() && std::memcmp(a.data(), b.data(), a.size() * sizeof(float)) == 0;
}

}  // namespace

int main(int argc, char **argv) {
    if (argc != 3) {
        std::fprintf(stderr, "usage: %s MODEL.dsm THREADS\n", argv[0]);
        return 2;
    }
    const int threads = std::atoi(argv[2]);
    DsModel *owned = nullptr;
    if (ds_model_open(argv[1], &owned) != DS_OK) {
        std::fprintf(stderr, "cannot open %s: %s\n", argv[1], ds_last_error_message());
        return 1;
    }
    const DsModel *m = owned;
    float lo[3], hi[3], t0, t1;
    ds_bounds(m, lo, hi);
    ds_time_range(m, &t0, &t1);
    std::vector<float> xyz(3 * kPoints), t(kPoints);
    for (size_t i = 0; i < kPoints; i++) {
        for (int d = 0; d < 3; d++) {
            const float u = static_cast<float>((i * (d + 3) * 7919) % 1000) / 1000.0f;
            xyz[3 * i + d] = lo[d] + (hi[d] - lo[d]) * u;
        }
        t[i] = t0 + (t1 - t0) * static_cast<float>(i % 97) / 96.0f;
    }

    const Answers reference = query(m, xyz, t, -1);
    std::vector<Answers> results(static_cast<size_t>(threads));
    std::atomic<int> ready{0};
    std::vector<std::thread> pool;
    for (int i = 0; i < threads; i++) {
        pool.emplace_back([&, i] {
            // Start together, so the queries really overlap.
            ready.fetch_add(1);
            while (ready.load() < threads) std::this_thread::yield();
            results[static_cast<size_t>(i)] = query(m, xyz, t, i);
        });
    }
    for (auto &th : pool) th.join();

    int failures = reference.ok ? 0 : 1;
    if (!reference.ok) std::fprintf(stderr, "reference run: %s\n", reference.failure.c_str());
    for (int i = 0; i < threads; i++) {
        const Answers &a = results[static_cast<size_t>(i)];
        const bool same = a.ok && same_bits(a.f, reference.f) &&
                          same_bits(a.grad, reference.grad) &&
                          same_bits(a.batch_f, reference.batch_f) &&
                          same_bits(a.batch_grad, reference.batch_grad) &&
                          a.labels == reference.labels && a.batch_labels == reference.batch_labels;
        if (!same) {
            failures++;
            std::fprintf(stderr, "thread %d differs from the single-threaded run %s\n", i,
                         a.failure.c_str());
        }
    }
    ds_model_free(owned);
    if (failures == 0) std::printf("%d threads: bit-identical to the single-threaded run\n", threads);
    std::printf("C++ threads test: %d passed, %d failed\n", threads + 1 - failures, failures);
    return failures == 0 ? 0 : 1;
}
