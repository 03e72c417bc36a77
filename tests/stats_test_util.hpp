// Monte Carlo estimates in tests (issue #39: one copy instead of two).
#pragma once

#include <algorithm>
#include <cmath>

namespace nephele::test {

struct MeanAndError {
    double mean = 0, error = 0;  // sample mean and its standard error
};

// The mean of sample(0) .. sample(n - 1), n >= 2, and its standard error sd / sqrt(n).
template <class F>
MeanAndError meanOf(int n, F&& sample) {
    double sum = 0, sum2 = 0;
    for (int i = 0; i < n; ++i) {
        const double v = sample(i);
        sum += v;
        sum2 += v * v;
    }
    const double mean = sum / n, var = std::max(0.0, (sum2 - n * mean * mean) / (n - 1));
    return {mean, std::sqrt(var / n)};
}

}  // namespace nephele::test
