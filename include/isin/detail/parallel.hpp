#pragma once
/// isin — private: the threads of render() and of the Bvh build. Every way a worker can fail
/// ends in the caller: a thread that cannot be started (a process limit, no memory) leaves its
/// work to the threads that did start, and an exception thrown inside a worker (a user's
/// primitive, std::bad_alloc) is rethrown by the call that started the workers, once every
/// thread it started has been joined. std::terminate is never reached from here.
#include <algorithm>
#include <atomic>
#include <cstddef>
#include <exception>
#include <thread>
#include <type_traits>
#include <utility>
#include <vector>

namespace isin::detail {

/// A callable passed by reference, its type erased (a pointer to it and to a function that calls
/// it): so that run_workers, parallel_chunks and fork_join are compiled once, not once for
/// every lambda handed to them — each copy of std::thread's machinery costs compile time in
/// every file that renders or builds a Bvh. The callable must outlive the call.
template <class Signature>
class FunctionRef;
template <class R, class... Args>
class FunctionRef<R(Args...)> {
public:
    template <class F, class = std::enable_if_t<!std::is_same_v<std::decay_t<F>, FunctionRef>>>
    FunctionRef(F&& f) noexcept // implicit: a lambda converts where a FunctionRef is expected
        : object_(const_cast<void*>(static_cast<const void*>(&f))), call_([](void* object, Args... args) -> R {
              return (*static_cast<std::remove_reference_t<F>*>(object))(std::forward<Args>(args)...);
          }) {}
    R operator()(Args... args) const { return call_(object_, std::forward<Args>(args)...); }

private:
    void* object_;
    R (*call_)(void*, Args...);
};

/// The first exception of several workers, and a flag the others can poll to stop early.
class FirstError {
public:
    /// Records the exception being handled, unless one was recorded before.
    void capture() noexcept {
        if (claimed_.exchange(true, std::memory_order_acq_rel)) return; // another worker's came first
        error_ = std::current_exception();
        failed_.store(true, std::memory_order_release);
    }
    [[nodiscard]] bool failed() const noexcept { return failed_.load(std::memory_order_relaxed); }
    /// Rethrows the recorded exception, if any; call it once the workers have been joined.
    void rethrow() const {
        if (failed_.load(std::memory_order_acquire)) std::rethrow_exception(error_);
    }

private:
    std::atomic<bool> claimed_{false}, failed_{false};
    std::exception_ptr error_;
};

/// The number of threads to use for `requested` (0 = every core; at least 1).
[[nodiscard]] inline int thread_count(int requested) noexcept {
    const int hw = int(std::thread::hardware_concurrency());
    return std::max(1, requested > 0 ? requested : hw);
}

/// Runs body(worker, error) for worker = 0 … count − 1: worker 0 on the calling thread, the others
/// on new threads, as many as can be started. Bodies must share their work out dynamically (e.g.
/// from an atomic counter), since fewer of them may run, and may poll error.failed() to stop
/// early. Joins every started thread, then rethrows the first exception of any body.
inline void run_workers(int count, FunctionRef<void(int, const FirstError&)> body) {
    FirstError error;
    const auto guarded = [&](int worker) noexcept {
        try {
            body(worker, error);
        } catch (...) {
            error.capture();
        }
    };
    std::vector<std::thread> threads;
    try {
        threads.reserve(std::size_t(std::max(0, count - 1)));
        for (int worker = 1; worker < count; ++worker) threads.emplace_back(guarded, worker);
    } catch (...) { // no more threads (or no memory to hold them): the started ones and this one do the work
    }
    guarded(0);
    for (std::thread& t : threads) t.join();
    error.rethrow();
}

/// Calls f(begin, end) over [0, n) in chunks of at least `min_chunk` items, on up to `threads`
/// threads (run_workers: chunks are taken from a shared counter, exceptions reach the caller).
inline void parallel_chunks(std::size_t n, int threads, std::size_t min_chunk,
                            FunctionRef<void(std::size_t, std::size_t)> f) {
    const std::size_t parts =
        std::max<std::size_t>(1, std::min(std::size_t(std::max(threads, 1)), n / std::max<std::size_t>(min_chunk, 1)));
    const std::size_t chunk = (n + parts - 1) / parts;
    std::atomic<std::size_t> next{0};
    run_workers(int(parts), [&](int, const FirstError& error) {
        for (std::size_t k; !error.failed() && (k = next.fetch_add(1)) < parts;)
            f(std::min(n, k * chunk), std::min(n, (k + 1) * chunk));
    });
}

/// Calls f(begin, end) over [0, n) in blocks of `block` items (the last may be shorter), taken in
/// turn from a shared counter by up to `threads` threads (run_workers); on this thread alone when
/// one thread or one block is all there is.
inline void parallel_blocks(std::size_t n, int threads, std::size_t block,
                            FunctionRef<void(std::size_t, std::size_t)> f) {
    block = std::max<std::size_t>(block, 1);
    const std::size_t blocks = n / block + (n % block != 0);
    const std::size_t workers = std::min(std::size_t(std::max(threads, 1)), blocks);
    if (workers <= 1) {
        if (n > 0) f(0, n);
        return;
    }
    std::atomic<std::size_t> next{0};
    run_workers(int(workers), [&](int, const FirstError& error) {
        for (std::size_t k; !error.failed() && (k = next.fetch_add(1)) < blocks;)
            f(k * block, std::min(n, (k + 1) * block));
    });
}

/// Runs a() on a new thread and b() on this one, then rethrows the first exception of either
/// once both have finished. When no thread can be started, a() runs here after b().
inline void fork_join(FunctionRef<void()> a, FunctionRef<void()> b) {
    FirstError error;
    std::thread worker;
    try {
        worker = std::thread([&]() noexcept {
            try {
                a();
            } catch (...) {
                error.capture();
            }
        });
    } catch (...) { // cannot start a thread: both run here
    }
    try {
        b();
    } catch (...) {
        error.capture();
    }
    if (worker.joinable()) {
        worker.join();
    } else if (!error.failed()) {
        try {
            a();
        } catch (...) {
            error.capture();
        }
    }
    error.rethrow();
}

} // namespace isin::detail
