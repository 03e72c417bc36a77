// Running the `nephele` binary from a test with its time and address space bounded.
#pragma once

#include "test_build.hpp"

#include <sys/wait.h>

#include <array>
#include <cstdio>
#include <string>

namespace nephele::test {

struct BoundedRun {
    int code = -1;       // exit code; -1 when killed (by the time limit) or not run
    std::string output;  // stdout and stderr
};

// `nephele ARGS` with its address space capped at `megabytes` and killed after `seconds`.
// In the sanitizer build there is no cap (ASan cannot start under one: the release build's run
// of the same test checks the memory bound) and the time is `seconds` x kTimeScale.
inline BoundedRun runBounded(const std::string& args, int megabytes, int seconds) {
    const std::string cap = kSanitized ? std::string() : "ulimit -v " + std::to_string(megabytes * 1024) + "; ";
    const std::string cmd = cap + "timeout -s KILL " + std::to_string(int(seconds * kTimeScale)) + " " + NEPHELE_BINARY +
                            " " + args + " 2>&1";
    FILE* pipe = popen(cmd.c_str(), "r");
    BoundedRun r;
    if (!pipe) return r;
    std::array<char, 512> buf;
    while (fgets(buf.data(), buf.size(), pipe)) r.output += buf.data();
    const int status = pclose(pipe);
    r.code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
    return r;
}

}  // namespace nephele::test
