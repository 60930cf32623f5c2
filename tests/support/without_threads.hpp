#pragma once
// Runs a check in a child process that cannot start threads, as under a process limit: the
// child's RLIMIT_NPROC is 0 (as root, after becoming user "nobody", since root is exempt from
// it). The check runs with no doctest macros (they belong to the parent) and returns whether it
// passed.
#include <cstdio>
#include <exception>
#include <thread>

#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

/// What happened to the check: it passed, failed, crashed (std::terminate included), or could not
/// be run because threads still started in the child.
enum class WithoutThreads { passed, failed, crashed, not_run };

template <class Check>
WithoutThreads without_threads(Check check) {
    std::fflush(nullptr);
    const pid_t pid = ::fork();
    if (pid < 0) return WithoutThreads::not_run;
    if (pid == 0) {
        if (::geteuid() == 0 && (::setgid(65534) != 0 || ::setuid(65534) != 0)) ::_exit(77);
        const rlimit none{0, 0};
        if (::setrlimit(RLIMIT_NPROC, &none) != 0) ::_exit(77);
        try {
            std::thread t([] {});
            t.join();
            ::_exit(77); // threads still start: this check cannot be made here
        } catch (const std::exception&) {}
        bool ok = false;
        try {
            ok = check();
        } catch (...) {
            ::_exit(3);
        }
        std::fflush(nullptr);
        ::_exit(ok ? 0 : 1);
    }
    int status = 0;
    while (::waitpid(pid, &status, 0) < 0) {}
    if (!WIFEXITED(status)) return WithoutThreads::crashed;
    switch (WEXITSTATUS(status)) {
    case 0: return WithoutThreads::passed;
    case 1: return WithoutThreads::failed;
    case 77: return WithoutThreads::not_run;
    default: return WithoutThreads::crashed;
    }
}
