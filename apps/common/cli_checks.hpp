// The command line's ranges: every setting has one, checked as the command line is parsed (a
// bad value exits 2 naming the flag) and shown in --help after the option's type.
#pragma once

#include <CLI/CLI.hpp>

#include <cstdio>
#include <string>

namespace nephele::cli {

inline std::string rangeNumber(double v) {
    char b[32];
    std::snprintf(b, sizeof b, "%.15g", v);
    return b;
}

// A number in [lo, hi]; NaN and infinities are refused too (a plain CLI::Range lets NaN through).
inline CLI::Validator within(double lo, double hi) {
    return CLI::Validator(
        [lo, hi](std::string& text) -> std::string {
            double v = 0;
            try {
                std::size_t used = 0;
                v = std::stod(text, &used);
                if (used != text.size()) return "'" + text + "' is not a number";
            } catch (const std::exception&) {
                return "'" + text + "' is not a number";
            }
            if (!(v >= lo && v <= hi))
                return "must be in " + rangeNumber(lo) + ".." + rangeNumber(hi) + ", got " + text;
            return "";
        },
        rangeNumber(lo) + ".." + rangeNumber(hi));
}

// A path: not empty (an empty -o would name no file).
inline CLI::Validator nonEmptyPath() {
    return CLI::Validator([](std::string& text) -> std::string { return text.empty() ? "the path is empty" : ""; },
                          "PATH");
}

}  // namespace nephele::cli
