#pragma once
// Runs fn(i) for i in [begin, end) on `threads` std::threads (interleaved indices, so each index is
// handled by exactly one thread and results written per index do not depend on the thread count).
// fn may also take (i, worker) with worker in [0, worker_count(threads, end - begin)), for per-thread
// state. The first exception thrown by any call is rethrown in the caller.
#include <algorithm>
#include <cstddef>
#include <exception>
#include <mutex>
#include <thread>
#include <type_traits>
#include <vector>

namespace facesynth::train {

[[nodiscard]] inline std::size_t worker_count(int threads, std::size_t count) {
    return std::clamp<std::size_t>(static_cast<std::size_t>(std::max(threads, 1)), 1, std::max<std::size_t>(count, 1));
}

template <typename Fn>
void parallel_for(std::size_t begin, std::size_t end, int threads, Fn&& fn) {
    const std::size_t count = end > begin ? end - begin : 0;
    const std::size_t workers = worker_count(threads, count);
    const auto call = [&fn](std::size_t i, std::size_t w) {
        if constexpr (std::is_invocable_v<Fn&, std::size_t, std::size_t>) {
            fn(i, w);
        } else {
            (void)w;
            fn(i);
        }
    };
    if (workers == 1) {
        for (std::size_t i = begin; i < end; ++i) call(i, 0);
        return;
    }
    std::exception_ptr failure;
    std::mutex failure_mutex;
    std::vector<std::thread> pool;
    pool.reserve(workers);
    for (std::size_t w = 0; w < workers; ++w) {
        pool.emplace_back([&, w] {
            try {
                for (std::size_t i = begin + w; i < end; i += workers) call(i, w);
            } catch (...) {
                const std::lock_guard lock(failure_mutex);
                if (!failure) failure = std::current_exception();
            }
        });
    }
    for (auto& t : pool) t.join();
    if (failure) std::rethrow_exception(failure);
}

}  // namespace facesynth::train
