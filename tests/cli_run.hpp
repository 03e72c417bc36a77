// Running the `nephele` binary from a test: the one process runner of the tests (issue #39).
//   runCli("render a.json -o b.png")       through the shell (its words split there), stdout and
//                                          stderr together, as a user types it;
//   spawnCli({"render", path, ...}, opts)  without a shell (any byte may be in an argument), with
//                                          the child's peak memory and CPU time, and on request a
//                                          time limit and ASAN_OPTIONS of its own;
//   runBounded(args, megabytes, seconds)   through the shell under `ulimit -v` and `timeout`.
#pragma once

#include "test_build.hpp"

#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <array>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

namespace nephele::test {

struct CliResult {
    int code = -1;          // exit code; -1 when killed (by a time limit) or not run
    std::string output;     // stdout and stderr
    long maxRssKb = 0;      // spawnCli only: the child's peak resident memory (KiB)
    double peakMb = 0;      // the same in MiB
    double cpuSeconds = 0;  // spawnCli only: the child's user + system time
};

// `nephele ARGS 2>&1` through the shell; `prefix` is shell text put before the binary (a
// `ulimit`, a `timeout`, variables).
inline CliResult runCli(const std::string& args, const std::string& prefix = "") {
    const std::string cmd = prefix + NEPHELE_BINARY + " " + args + " 2>&1";
    FILE* pipe = popen(cmd.c_str(), "r");
    CliResult r;
    if (!pipe) {
        r.output = "popen failed";
        return r;
    }
    std::array<char, 512> buf;
    while (fgets(buf.data(), buf.size(), pipe)) r.output += buf.data();
    const int status = pclose(pipe);
    r.code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
    return r;
}

struct SpawnOptions {
    double seconds = 0;       // > 0: SIGALRM ends the child after seconds x kTimeScale
    std::string asanOptions;  // appended to ASAN_OPTIONS for the child (only a sanitizer build reads them)
};

// `nephele ARGS...` without a shell, its peak memory and CPU time from wait4.
inline CliResult spawnCli(const std::vector<std::string>& args, const SpawnOptions& o = {}) {
    int fds[2];
    if (::pipe(fds) != 0) return {};
    const pid_t pid = ::fork();
    if (pid == 0) {
        if (!o.asanOptions.empty()) {
            const char* before = std::getenv("ASAN_OPTIONS");
            ::setenv("ASAN_OPTIONS",
                     ((before && *before ? std::string(before) + ":" : std::string()) + o.asanOptions).c_str(), 1);
        }
        ::dup2(fds[1], 1), ::dup2(fds[1], 2);
        ::close(fds[0]), ::close(fds[1]);
        if (o.seconds > 0) ::alarm(unsigned(std::ceil(o.seconds * kTimeScale)));  // SIGALRM kills it when it is late
        std::vector<char*> argv{const_cast<char*>(NEPHELE_BINARY)};
        for (const std::string& a : args) argv.push_back(const_cast<char*>(a.c_str()));
        argv.push_back(nullptr);
        ::execv(NEPHELE_BINARY, argv.data());
        ::_exit(127);
    }
    ::close(fds[1]);
    CliResult r;
    char buf[4096];
    for (ssize_t n; (n = ::read(fds[0], buf, sizeof buf)) > 0;) r.output.append(buf, std::size_t(n));
    ::close(fds[0]);
    int status = 0;
    rusage u{};
    ::wait4(pid, &status, 0, &u);
    r.code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
    r.maxRssKb = u.ru_maxrss;
    r.peakMb = double(u.ru_maxrss) / 1024.0;
    r.cpuSeconds =
        double(u.ru_utime.tv_sec + u.ru_stime.tv_sec) + 1e-6 * double(u.ru_utime.tv_usec + u.ru_stime.tv_usec);
    return r;
}

using BoundedRun = CliResult;

// `nephele ARGS` with its address space capped at `megabytes` and killed after `seconds`.
// In the sanitizer build there is no cap (ASan cannot start under one: the release build's run
// of the same test checks the memory bound) and the time is `seconds` x kTimeScale.
inline BoundedRun runBounded(const std::string& args, int megabytes, int seconds) {
    const std::string cap = kSanitized ? std::string() : "ulimit -v " + std::to_string(megabytes * 1024) + "; ";
    return runCli(args, cap + "timeout -s KILL " + std::to_string(int(seconds * kTimeScale)) + " ");
}

}  // namespace nephele::test
